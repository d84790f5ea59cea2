"""How the joint multi-channel AGB error depends on the exponents it assumes (docs/theory/retrieval.md, Section 7.3).

The exponents alpha_pq of the per-channel power laws set the joint estimate's weights c = alpha / (alpha . alpha)
(BIOMASS AGB ATBD, eqs. 4.26-4.37), so they decide how much of each channel's error reaches the AGB: a channel with a
larger exponent gets more weight and brings its own speckle realisation. If nature's exponent of a channel is
another, the processor fits that one, and the estimate is another estimate with another error. This is not an error
of the estimate (the model term, ``e2esim.retrieval.model_error``, is that) but an uncertainty of the simulator's
answer, so it is reported beside it: the analytic RMSE of every source with one channel's exponent at the ends of its
stated range, alpha_pq -/+ its SD, the others kept, from the same joint moments of the channel errors (co-pol eqs.
8.3-8.4: only the weights change, the scene's powers do not).
"""

from __future__ import annotations

import numpy as np

from e2esim.retrieval.agb_error import AGBError
from e2esim.retrieval.multichannel import CHANNELS, LogErrorMap, log_agb_moments


def joint_rmse(mean_relative, covariance_relative, weights, model_variance: float = 0.0) -> float:
    """Analytic RMSE of the relative AGB error of the joint estimate with weights c, for relative channel errors of
    mean (3,) and covariance (3, 3) (systematic and random together), plus the model term's variance."""
    mean, var = log_agb_moments(weights, mean_relative, covariance_relative)
    sd = float(np.sqrt(max(float(var), 0.0) + model_variance))
    return AGBError(1.0, 1.0, float(mean), sd, mapping=LogErrorMap()).rmse()


def exponent_sensitivity(alpha, spread, mean_relative, covariance_relative, model_variance_of) -> tuple:
    """((name, value), ...) of the RMSE (percent) with channel pq's exponent at alpha_pq - spread_pq ("low") and
    alpha_pq + spread_pq ("high"), for every channel with a spread: ``<pq>.low_exponent``, ``<pq>.low_rmse_percent``,
    ``<pq>.high_exponent``, ``<pq>.high_rmse_percent``. ``model_variance_of(alpha, weights)`` gives the model term
    at other exponents (0 without one). A low end below zero is taken as 0: the channel then carries no AGB
    information and no weight."""
    alpha = np.asarray(alpha, dtype=float)
    out = []
    for k, channel in enumerate(CHANNELS):
        if not spread[k] > 0:
            continue
        for side, value in (("low", max(alpha[k] - spread[k], 0.0)), ("high", alpha[k] + spread[k])):
            a = alpha.copy()
            a[k] = value
            weights = a / (a @ a)
            rmse = joint_rmse(mean_relative, covariance_relative, weights, model_variance_of(a, weights))
            out += [(f"{channel}.{side}_exponent", float(value)), (f"{channel}.{side}_rmse_percent", 100.0 * rmse)]
    return tuple(out)
