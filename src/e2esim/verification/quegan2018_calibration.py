"""Recompute the calibration statements of Quegan et al. (2018) (ids in ``quegan2018_calibration_values``).

BIOMASS conditions: crosstalk -30 dB and channel imbalance -34 dB (3-sigma labels, correlations 0.9 e^{j0},
Men et al. 2021, Section IV), NESZ -27 dB (Men et al. 2021, Table III), the boreal 200 t/ha and tropical
338 t/ha forests of Men et al. (2021), Table I, with Faraday rotation N(60 deg, 5 deg) and N(0, 5 deg),
the pi/2 ambiguity resolved with the climatological mean. Window: L = 96 independent samples, the 200 m
(4 ha) AGB product pixel (16 ground pixels of 50 m x 50 m with 6 azimuth looks each, Quegan et al. 2018,
Section 6), the smallest window a product would use; Section 6's best case is L = 10^4 (2 km x 2 km).
"""

from __future__ import annotations

import numpy as np

from e2esim.calibration.pipeline import ResidualSampler
from e2esim.calibration.steps import FaradayStep
from e2esim.faraday.distribution import GaussianFaraday
from e2esim.faraday.estimator_modules import BickelBatesEstimator
from e2esim.faraday.theory import bickel_bates_snr, bickel_bates_variance
from e2esim.verification.men2021 import forest, system

WINDOW_LOOKS = 96  # 200 m AGB product pixel: 16 pixels of 50 m x 50 m, 6 looks each (Section 6)
CASES = (("boreal_200", 60.0), ("tropical_338", 0.0))  # Men et al. (2021), Table III: mean FR boreal pi/3, tropical 0
FR_SD_DEG = 5.0  # spread of the Faraday rotation about its mean (used for the ambiguity prior)
REALISATIONS = 20_000
SEED = 2018  # fixed so that `e2esim reproduce` is repeatable
QUANTILE = 0.99865  # one-sided 3-sigma level, as for the AGB requirement of Men et al. (2021)


def fr_errors(forest_name: str, mean_deg: float, looks: int = WINDOW_LOOKS, crosstalk_db: float = -30.0,
              n: int = REALISATIONS, seed: int = SEED) -> np.ndarray:
    """Bickel-Bates errors Omega_hat - Omega (deg) over system errors, speckle and noise."""
    scene = forest(forest_name)
    sys_model = system(crosstalk_db, -34.0)
    fr = GaussianFaraday(np.radians(mean_deg), np.radians(FR_SD_DEG))
    step = FaradayStep(BickelBatesEstimator(), looks=looks)
    sampler = ResidualSampler(sys_model, fr, scene, sys_model.noise_power, (step,))
    res = sampler.sample(np.random.default_rng(seed), n)
    return np.degrees(res.diagnostics[0].omega_error)


def fr_correction_accuracy(record):
    """The 99.865 % quantile of |Omega_hat - Omega| (deg), the worse of the two forests, and the conditions
    under which 1 deg holds (looks for the noise term alone; crosstalk level for the bias term)."""
    quantiles, notes = [], []
    for name, mean in CASES:
        err = fr_errors(name, mean)
        q = float(np.quantile(np.abs(err), QUANTILE))
        quantiles.append(q)
        snr = bickel_bates_snr(forest(name), system(-30.0, -34.0).noise_power)
        looks_1deg = _looks_for(1.0 / 3.0, snr)
        bias = fr_errors(name, mean, looks=10**9, n=5000)  # window so large that only the crosstalk bias is left
        q_bias = float(np.quantile(np.abs(bias), QUANTILE))
        xt_1deg = -30.0 + 20 * np.log10(1.0 / q_bias)  # the bias is first order in the crosstalk amplitude
        notes.append(
            f"{name}: 99.865 % |error| {q:.2f} deg, RMS {np.sqrt(np.mean(err**2)):.2f} deg at L = {WINDOW_LOOKS}, "
            f"SNR {10 * np.log10(snr):.1f} dB; the noise term alone stays below 1 deg (3 sigma) for "
            f"L >= {looks_1deg}; the crosstalk bias ({q_bias:.2f} deg) reaches 1 deg at about {xt_1deg:.0f} dB"
        )
    computed = max(quantiles)
    note = ("computed = worse 99.865 % quantile of |Omega_hat - Omega| over system errors, speckle and noise, "
            "BIOMASS specification, NESZ -27 dB; the bound is met when it is below 1 deg. " + "; ".join(notes))
    return computed, None, note


def _looks_for(sd_deg: float, snr: float) -> int:
    """Smallest L with exact Bickel-Bates SD <= sd_deg (bisection on the exact variance)."""
    lo, hi = 1, 1
    while np.degrees(np.sqrt(bickel_bates_variance(snr, hi))) > sd_deg:
        lo, hi = hi, hi * 2
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if np.degrees(np.sqrt(bickel_bates_variance(snr, mid))) > sd_deg:
            lo = mid
        else:
            hi = mid
    return hi
