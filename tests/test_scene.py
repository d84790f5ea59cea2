"""Scene covariances: Table I, the AGB model, validity checks and sampling."""

import numpy as np
import pytest

from e2esim.errors import PhysicsInputError
from e2esim.scene.agb_model import forest_covariance
from e2esim.scene.covariance import ScatteringCovariance
from e2esim.scene.table1 import TABLE1_FORESTS
from helpers import Z_ACCEPT, forest


def test_table1_values():
    # Men et al. (2021), Table I, boreal 200 t/ha.
    c = forest("boreal_200")
    assert (c.sigma_hh, c.sigma_hv, c.sigma_vv) == (0.649, 0.0726, 0.274)
    assert c.hhvv_magnitude == pytest.approx(0.150)
    assert np.degrees(c.hhvv_phase_rad) == pytest.approx(-96.8)
    assert c.is_reflection_symmetric()
    assert len(TABLE1_FORESTS) == 5


def test_non_hermitian_covariance_is_rejected():
    m = np.diag([1.0, 0.1, 0.5]).astype(complex)
    m[0, 2] = 0.2
    with pytest.raises(PhysicsInputError, match="not Hermitian"):
        ScatteringCovariance(m)


def test_indefinite_covariance_is_rejected_with_a_useful_message():
    with pytest.raises(PhysicsInputError, match=r"not positive semi-definite.*sqrt\(sigma_hh sigma_vv\)"):
        ScatteringCovariance.from_powers(0.2, 0.05, 0.2, 0.3, 0.0)  # |<hh vv*>| > sqrt(0.2*0.2)


def test_zero_power_is_rejected():
    with pytest.raises(PhysicsInputError, match="must be > 0"):
        ScatteringCovariance.from_powers(0.2, 0.0, 0.2, 0.0, 0.0)


def test_singular_covariance_can_be_sampled(rng):
    c = ScatteringCovariance.from_powers(0.2, 0.05, 0.2, 0.2, 0.3)  # |rho_hhvv| = 1
    s = c.sample(rng, 20_000)
    est = s.T @ s.conj() / s.shape[0]
    assert abs(est[0, 2] - c.hhvv) < 0.01


def test_cholesky_sampling_reproduces_the_covariance(rng):
    c = forest("boreal_350")
    n = 200_000
    s = c.sample(rng, n)
    for i, j in [(0, 0), (1, 1), (2, 2), (0, 2)]:
        prod = s[:, i] * np.conj(s[:, j])
        assert abs(prod.mean() - c.matrix[i, j]) < Z_ACCEPT * np.sqrt(np.var(prod) / n)
    assert abs(np.mean(s[:, 0] * np.conj(s[:, 1]))) < Z_ACCEPT * np.sqrt(c.sigma_hh * c.sigma_hv / n)


def test_wishart_sample_covariance_has_the_right_first_two_moments(rng):
    # L C_hat ~ complex Wishart: E[C_hat] = C, Var(C_hat_ii) = C_ii^2 / L, E|C_hat_ij - C_ij|^2 = C_ii C_jj / L.
    c, looks, n = forest("boreal_200"), 25, 40_000
    w = c.sample_covariance(rng, looks, n)
    direct = c.sample(rng, (n, looks))
    direct = np.einsum("nki,nkj->nij", direct, direct.conj()) / looks
    for sample in (w, direct):
        hv = sample[:, 1, 1].real
        assert abs(hv.mean() - c.sigma_hv) < Z_ACCEPT * hv.std() / np.sqrt(n)
        rel_var = hv.var() / (c.sigma_hv**2 / looks)
        assert abs(rel_var - 1) < Z_ACCEPT * np.sqrt((2 + 6 / looks) / n)  # Gamma(L) kurtosis 3 + 6/L
        hhvv = sample[:, 0, 2]
        assert abs(hhvv.mean() - c.hhvv) < Z_ACCEPT * np.sqrt(c.sigma_hh * c.sigma_vv / looks / n)
        dev2 = np.abs(hhvv - c.hhvv) ** 2
        expected = c.sigma_hh * c.sigma_vv / looks
        assert abs(dev2.mean() - expected) < Z_ACCEPT * dev2.std() / np.sqrt(n)


def test_agb_model_is_continuous_and_follows_the_power_law():
    p = 2.2
    a, b = forest_covariance("boreal", 100.0), forest_covariance("boreal", 300.0)
    assert b.sigma_hv / a.sigma_hv == pytest.approx(3.0 ** (1 / p))  # eq. (15)
    # near the Table I points the model stays within a few percent of the table
    for name in ("boreal_50", "boreal_200", "boreal_350"):
        t = forest(name)
        m = forest_covariance("boreal", t.agb_t_ha)
        assert m.sigma_hv == pytest.approx(t.sigma_hv, rel=0.04)
        assert m.sigma_hh / m.sigma_hv == pytest.approx(t.sigma_hh / t.sigma_hv, rel=1e-9)
    eps = 1e-6
    lo, hi = forest_covariance("boreal", 200 - eps), forest_covariance("boreal", 200 + eps)
    assert lo.sigma_hh == pytest.approx(hi.sigma_hh, rel=1e-6)


def test_agb_model_rejects_unknown_biome():
    with pytest.raises(PhysicsInputError, match="no Table I forests for biome 'savanna'"):
        forest_covariance("savanna", 100.0)
