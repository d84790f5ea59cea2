"""The multi-channel AGB estimate of a multi-pass estimator (kind ``retrieval``): issue 12's HH+HV+VV estimate
of the BIOMASS AGB ATBD on ground-cancelled channels, with the exponents of the ground-cancelled power laws.

The ATBD estimates AGB from the ground-cancelled HH, HV and VV (BPS AGB ATBD Sections 2.2, 3.4, eqs. 4.8-4.10;
Soja et al. 2021). The project found no published exponents of the ground-cancelled power laws (it looked in Soja et
al. 2021 and Banda et al. 2020; the ATBD fits them per block, eq. 4.19, and states none; the BioPAL prototype only
bounds them, 0.1 to 1.9 for every channel), so they are a stated model of the scene's random-volume-over-ground split,
per channel (ground-cancellation.md, eq. 24):

* ``rvog``: the ground term does not change with AGB and the volume carries all of the AGB dependence, so the
  cancelled channel follows the volume alone, alpha_GC = alpha (1 + mu_pq) (eq. 19 for every channel);
* ``volume``: the cancelled channel is the volume's, and the volume's channels change alike with AGB (a random
  volume of one polarimetric shape, the RVoG scene of ground-cancellation.md Section 1.2), so it takes the exponent
  of the ground-cancelled HV (its ``rvog`` value);
* ``same``: the biome's exponent of the channel (ground and volume change alike with AGB).

Default: ``volume`` for HH and ``rvog`` for HV and VV. Ground cancellation removes the direct and the double-bounce
ground returns (Quegan et al. 2019, abstract), so the double bounce that makes HH's biome exponent steep (and that
carries AGB information in boreal forest, ibid.) is gone: ``same`` keeps an exponent the cancelled channel has lost.
In tropical forest the tomographic layer 30 m above the ground, the volume, correlates best with AGB and with the
largest sensitivity in every polarisation (Ho Tong Minh et al. 2014, abstract), which ``volume`` states. ``rvog``
cannot hold for HH: with the boreal preset's mu_hh = +3 dB an AGB-independent ground would be larger than the whole HH
power of the 50 t/ha boreal forest of Men et al. (2021), Table I (0.432 against 0.213). For HV and VV it can
(0.024 < 0.040, 0.137 < 0.250); VV keeps it (``volume`` would give VV the weight of HV and lower the error: the
conservative choice). With the biome exponents of ``e2esim.retrieval.multichannel.TABLE1_ALPHA`` this gives
(hh, hv, vv) = (0.579, 0.579, 0.077) tropical and (0.682, 0.682, 0.122) boreal. The HH exponent's SD for the model
term and the sensitivity is the distance between ``volume`` and ``same`` (0.225 tropical, 0.122 boreal; stated
assumption, ``e2esim.retrieval.model_error``). Single-date and multi-date estimates keep the biome's exponents.
"""

from __future__ import annotations

import numpy as np

from e2esim.params import Param
from e2esim.retrieval.multichannel import TABLE1_ALPHA
from e2esim.retrieval.multichannel_modules import MultiChannelRetrieval
from e2esim.stack.sites import ground_cancelled_exponent

CHANNEL_RULES = ("rvog", "volume", "same")
DEFAULT_RULES = ("volume", "rvog", "rvog")
"""Exponent rule of each ground-cancelled channel (hh, hv, vv) (module docstring)."""


def ground_cancelled_alphas(alpha, ground_to_volume_db, rules=DEFAULT_RULES) -> np.ndarray:
    """alpha_GC of (hh, hv, vv): alpha (1 + mu) where the rule is ``rvog`` (eq. 24, the alpha = 1/p form of
    ``ground_cancelled_exponent``), the ground-cancelled HV's alpha_hv (1 + mu_hv) where it is ``volume``, alpha where
    it is ``same``."""
    rvog = [1.0 / ground_cancelled_exponent(1.0 / a, mu) for a, mu in zip(alpha, ground_to_volume_db)]
    return np.array([rvog[k] if rule == "rvog" else rvog[1] if rule == "volume" else float(alpha[k])
                     for k, rule in enumerate(rules)])


class StackMultiChannelRetrieval(MultiChannelRetrieval):
    """sigma0_pq = L_pq AGB^alpha_pq cos^n_pq(theta) for the channels of a multi-pass estimate; AGB from HH, HV and
    VV together (or one channel), with ground-cancelled exponents for ground-cancelled data (module docstring)."""

    type_name = "stack_multichannel_power_law"
    summary = ("multichannel_power_law for multi-pass estimates: ground-cancelled HH, HV, VV with the exponents of "
               "the scene's RVoG split (rvog), of the volume (volume) or the biome's (same), per channel")
    params = MultiChannelRetrieval.params + (
        Param("ground_cancelled_exponents", "str", "exponent rule of each ground-cancelled channel (hh, hv, vv) "
              "when alpha is null: rvog (alpha (1 + mu_pq)), volume (the ground-cancelled HV's) or same (the "
              "biome's)", default=DEFAULT_RULES, length=3, choices=CHANNEL_RULES),
    )
    uses = MultiChannelRetrieval.uses + ("scene.stack",)

    def _cancelled(self, case) -> bool:
        combination = getattr(case["backscatter.error"], "combination", None)
        return getattr(combination, "kind", None) == "ground_cancelled"

    def case_alpha(self, case) -> np.ndarray:
        alpha = self.alpha_for(case["scene.covariance"])
        if self.si["alpha"] is None and self._cancelled(case):
            mu = case["scene.stack"].forest.ground_to_volume_db
            return ground_cancelled_alphas(alpha, mu, tuple(self.si["ground_cancelled_exponents"]))
        return alpha

    def case_hh_spread(self, case) -> float | None:
        """|alpha_hh (same) - alpha_hh (volume)| of ground-cancelled data (module docstring), else None."""
        scene = case["scene.covariance"]
        if not self._cancelled(case) or scene.biome not in TABLE1_ALPHA:
            return None
        alpha = TABLE1_ALPHA[scene.biome]  # the biome's, also where the scenario gives the exponents
        volume = ground_cancelled_alphas(alpha, case["scene.stack"].forest.ground_to_volume_db, ("volume",) * 3)
        return abs(float(alpha[0]) - float(volume[0]))
