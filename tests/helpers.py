"""Small builders shared by the tests (not fixtures, so they can take arguments)."""

from __future__ import annotations

import os
import secrets

import numpy as np

from e2esim.instrument.system_errors import SystemErrorModel
from e2esim.scene.covariance import ScatteringCovariance
from e2esim.scene.table1 import TABLE1_FORESTS
from e2esim.units import THREE_SIGMA_AMPLITUDE, db_to_linear, variance_from_level_db

_env = os.environ.get("E2ESIM_TEST_SEED", "20210406")
TEST_SEED = secrets.randbelow(2**31) if _env == "random" else int(_env)
"""Root seed of the statistical tests (E2ESIM_TEST_SEED: an integer, or ``random``)."""

Z_ACCEPT = 4.5
"""Acceptance for single statistical comparisons: two-sided false-failure probability 7e-6 per
comparison, so a suite of a few hundred comparisons fails by chance about once in 500 runs."""


def forest(name: str = "boreal_200") -> ScatteringCovariance:
    biome, agb, hh, hv, vv, r, theta = TABLE1_FORESTS[name]
    return ScatteringCovariance.from_powers(hh, hv, vv, r, np.radians(theta), agb_t_ha=agb, biome=biome)


def system(crosstalk_db=-30.0, imbalance_db=-34.0, rho=0.9, nesz_db=-27.0, **kw) -> SystemErrorModel:
    """The paper's structure: equal variances, both pairs correlated with ``rho``, 3-sigma labels."""
    rho13 = kw.pop("rho13", rho)
    rho24 = kw.pop("rho24", rho)
    rho_eps = kw.pop("rho_eps", rho)
    return SystemErrorModel(
        crosstalk_level=float(variance_from_level_db(crosstalk_db, THREE_SIGMA_AMPLITUDE)),
        imbalance_level=float(variance_from_level_db(imbalance_db, THREE_SIGMA_AMPLITUDE)),
        crosstalk_rho13=rho13,
        crosstalk_rho24=rho24,
        imbalance_rho=rho_eps,
        noise_power=0.0 if nesz_db is None else float(db_to_linear(nesz_db)),
        **kw,
    )


def mean_and_variance_z(errors, mean, variance):
    """z-scores of the sample mean and variance of i.i.d. errors against expected values."""
    e = np.ravel(errors)
    n = e.size
    m, v = e.mean(), e.var(ddof=1)
    kurt = np.mean((e - m) ** 4) / v**2
    return (m - mean) / np.sqrt(v / n), (v - variance) / (v * np.sqrt((kurt - 1) / n))
