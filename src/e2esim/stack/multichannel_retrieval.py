"""The multi-channel AGB estimate of a multi-pass estimator (kind ``retrieval``): issue 12's HH+HV+VV estimate
of the BIOMASS AGB ATBD on ground-cancelled channels, with the exponents of the ground-cancelled power laws.

The ATBD estimates AGB from the ground-cancelled HH, HV and VV (BPS AGB ATBD Sections 2.2, 3.4, eqs. 4.8-4.10;
Soja et al. 2021). The project found no published per-site exponents of the ground-cancelled power laws (it
looked in Soja et al. 2021 and Banda et al. 2020), so they are a stated model of
the scene's random-volume-over-ground split, per channel (ground-cancellation.md, eq. 24):

* ``rvog``: the ground term does not change with AGB and the volume carries all of the AGB dependence, so the
  cancelled channel follows the volume alone, alpha_GC = alpha (1 + mu_pq) (eq. 19 for every channel);
* ``same``: the biome's exponent of the channel (ground and volume change alike with AGB).

Default: ``same`` for HH and ``rvog`` for HV and VV. HH's ground term is mostly double bounce, which carries AGB
information (Quegan et al. 2019, for boreal forest, abstract), and with the boreal preset's mu_hh = +3 dB an
AGB-independent ground would be larger than the whole HH power of the 50 t/ha boreal forest of Men et al. (2021),
Table I (0.432 against 0.213): ``rvog`` cannot hold for HH. For HV and VV it can (0.024 < 0.040, 0.137 < 0.250),
and HV then takes the exponent of the ground-cancelled HV power law (``stack_power_law``, ``rvog``). With the
biome exponents of ``e2esim.retrieval.multichannel.TABLE1_ALPHA`` this gives (hh, hv, vv) = (0.804, 0.579, 0.077)
tropical and (0.804, 0.682, 0.122) boreal. Single-date and multi-date estimates keep the biome's exponents.
"""

from __future__ import annotations

import numpy as np

from e2esim.params import Param
from e2esim.retrieval.multichannel_modules import MultiChannelRetrieval
from e2esim.stack.retrieval import GROUND_CANCELLED_EXPONENTS
from e2esim.stack.sites import ground_cancelled_exponent

DEFAULT_RULES = ("same", "rvog", "rvog")
"""Exponent rule of each ground-cancelled channel (hh, hv, vv) (module docstring)."""


def ground_cancelled_alphas(alpha, ground_to_volume_db, rules=DEFAULT_RULES) -> np.ndarray:
    """alpha_GC of (hh, hv, vv): alpha (1 + mu) where the rule is ``rvog`` (eq. 24, the alpha = 1/p form of
    ``ground_cancelled_exponent``), alpha where it is ``same``."""
    return np.array([1.0 / ground_cancelled_exponent(1.0 / a, mu) if rule == "rvog" else float(a)
                     for a, mu, rule in zip(alpha, ground_to_volume_db, rules)])


class StackMultiChannelRetrieval(MultiChannelRetrieval):
    """sigma0_pq = L_pq AGB^alpha_pq cos^n_pq(theta) for the channels of a multi-pass estimate; AGB from HH, HV and
    VV together (or one channel), with ground-cancelled exponents for ground-cancelled data (module docstring)."""

    type_name = "stack_multichannel_power_law"
    summary = ("multichannel_power_law for multi-pass estimates: ground-cancelled HH, HV, VV with the exponents of "
               "the scene's RVoG split (rvog) or the biome's (same), per channel")
    params = MultiChannelRetrieval.params + (
        Param("ground_cancelled_exponents", "str", "exponent rule of each ground-cancelled channel (hh, hv, vv) "
              "when alpha is null: rvog (alpha (1 + mu_pq)) or same (the biome's)", default=DEFAULT_RULES,
              length=3, choices=GROUND_CANCELLED_EXPONENTS),
    )
    uses = MultiChannelRetrieval.uses + ("scene.stack",)

    def case_alpha(self, case) -> np.ndarray:
        alpha = self.alpha_for(case["scene.covariance"])
        combination = getattr(case["backscatter.error"], "combination", None)
        if self.si["alpha"] is None and getattr(combination, "kind", None) == "ground_cancelled":
            mu = case["scene.stack"].forest.ground_to_volume_db
            return ground_cancelled_alphas(alpha, mu, tuple(self.si["ground_cancelled_exponents"]))
        return alpha
