"""The plug-in's error terms: amplitude scintillation and quantisation noise, each one more source of the
propagation's error model, whichever propagation module made it.

``scintillation`` multiplies the measured intensity by a factor g independent of everything else, E[g] = 1,
Var[g] = V (``Scintillation.variance``): with ``e = sigma_hat - sigma`` of mean m and variance v (the wrapped
model), ``e' = sigma_hat g - sigma`` has, exactly,

    E[e'] = m,        Var[e'] = E[sigma_hat^2] E[g^2] - E[sigma_hat]^2 = v (1 + V) + (sigma + m)^2 V

(e2esim's ``GammaFactor``, which also gives the covariance of several channels). V is a level ("scintillation"),
so requirement margins find how much scintillation a mission can take; "scintillation" is a source, so the
attribution says how much it adds.

``quantisation`` adds the noise of the on-board quantiser, whose power is the signal's divided by the
signal-to-quantisation-noise ratio (SQNR): N_p = q sigma_p, q = 10^(-SQNR/10), independent in every channel and
look, and not removed by the processor (e2esim's ``AddedPower``: E[e'] = m + N, Var[e'] = v + (N^2 + 2 a N) / L).
Its level is q, so the margin says which SQNR the mission needs. For Gaussian data the optimum 3-bit (8-level)
quantiser of Max (1960, IRE Trans. Inf. Theory 6(1), 7-12, Table I: mean squared error 0.03454) has
SQNR = 14.62 dB, the default.
"""

from __future__ import annotations

import numpy as np

from e2esim.error_terms.effects import AddedPower, GammaFactor
from e2esim.error_terms.modules import ErrorTerm, source_param
from e2esim.params import Param

MAX_3BIT_SQNR_DB = -10 * np.log10(0.03454)
"""SQNR of the optimum 8-level quantiser for Gaussian data (Max 1960, Table I), 14.62 dB."""


class ScintillationTerm(ErrorTerm):
    """Amplitude scintillation as a multiplicative intensity factor of variance S4^2 / N (the product
    ``ionosphere.scintillation`` of the stage ``scintillation.s4_index``)."""

    type_name = "scintillation"
    summary = "amplitude scintillation as a gamma intensity factor of mean 1 (example plug-in)"
    params = (source_param("scintillation"),)
    needs = ("ionosphere.scintillation",)

    effects_take_blocks = True  # its effect reads the case's products and settings only, draws nothing

    def effect(self, case, model):
        return GammaFactor(self.source, case["ionosphere.scintillation"].variance,
                           "amplitude scintillation (multiplicative intensity factor)")


class QuantisationTerm(ErrorTerm):
    """Quantisation noise of power sigma_p / SQNR in every channel, not removed (module docstring)."""

    type_name = "quantisation"
    summary = "quantisation noise of a given SQNR added to every channel (example plug-in)"
    params = (
        Param("sqnr_db", "float", "signal-to-quantisation-noise ratio of the on-board quantiser "
              "(default: optimum 3-bit quantiser, Max 1960)", default=round(float(MAX_3BIT_SQNR_DB), 2), unit="dB"),
        source_param("quantisation"),
    )

    effects_take_blocks = True  # its effect reads the case's products and settings only, draws nothing

    def effect(self, case, model):
        values = np.atleast_1d(np.asarray(getattr(model, "values", model.value), dtype=float))
        return AddedPower(self.source, 1.0 / self.si["sqnr_linear"], "quantisation noise (Max 1960)",
                          scale=tuple(values), looks=case.settings.looks)
