"""Builders and statistics shared by the calibration tests (imported as ``cal_helpers``)."""

from __future__ import annotations

import numpy as np

from e2esim.instrument.system_errors import SystemErrorModel
from e2esim.scene.covariance import ScatteringCovariance
from e2esim.scene.table1 import TABLE1_FORESTS
from e2esim.units import THREE_SIGMA_AMPLITUDE, db_to_linear, variance_from_level_db

Z_ACCEPT = 4.5
"""Two-sided false-failure probability 7e-6 per comparison."""


def forest(name: str = "boreal_200") -> ScatteringCovariance:
    biome, agb, hh, hv, vv, r, theta = TABLE1_FORESTS[name]
    return ScatteringCovariance.from_powers(hh, hv, vv, r, np.radians(theta), agb_t_ha=agb, biome=biome)


def biomass_system(crosstalk_db=-30.0, imbalance_db=-34.0, rho=0.9, nesz_db=-27.0) -> SystemErrorModel:
    """BIOMASS specification in the structure of Men et al. (2021): 3-sigma labels, pair correlations rho."""
    return SystemErrorModel(
        crosstalk_level=float(variance_from_level_db(crosstalk_db, THREE_SIGMA_AMPLITUDE)),
        imbalance_level=float(variance_from_level_db(imbalance_db, THREE_SIGMA_AMPLITUDE)),
        crosstalk_rho13=rho, crosstalk_rho24=rho, imbalance_rho=rho,
        noise_power=0.0 if nesz_db is None else float(db_to_linear(nesz_db)),
    )


def z_mean(x, expected) -> float:
    """z-score of a sample mean against its expectation."""
    x = np.ravel(x)
    return float((x.mean() - expected) / (x.std(ddof=1) / np.sqrt(x.size)))


def z_variance(x, expected) -> float:
    """z-score of a sample variance (about the known mean 0 or the sample mean) against its expectation,
    with the standard error from the sample kurtosis."""
    x = np.ravel(x) - np.mean(x)
    v = x.var(ddof=1)
    kurt = np.mean(x**4) / v**2
    return float((v - expected) / (v * np.sqrt((kurt - 1) / x.size)))
