"""The azimuth response through a phase screen: the Monte Carlo of the 1-D azimuth compression against closed forms
(white phase error, quadratic phase error) and against the weak-scatter theory (docs/theory/scintillation.md)."""

import math

import numpy as np
import pytest

from e2esim.scintillation.aperture import aperture_grid, biomass_aperture, two_way_structure
from e2esim.scintillation.defocus import broadening, defocus_peak
from e2esim.scintillation.irf import compress, ideal_response, irf_metrics, monte_carlo_irf, phase_draws
from e2esim.scintillation.irf_analytic import analytic_irf

N, OS = 128, 16


def test_undistorted_response_is_the_uniform_aperture_sinc():
    """|sinc|^2: 3-dB width 0.886 cells, PSLR -13.26 dB, ISLR -9.68 dB (Cumming & Wong 2005, Table 2.3)."""
    peak, width = ideal_response(N, OS)
    m = irf_metrics(compress(np.zeros((1, N)), None, OS), OS, peak, width)
    assert width == pytest.approx(0.886, abs=1e-3)
    assert m["pslr_db"][0] == pytest.approx(-13.26, abs=0.01)
    assert m["islr_db"][0] == pytest.approx(-9.68, abs=0.02)
    assert m["shift_cells"][0] == 0.0 and m["peak_loss_db"][0] == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("sigma", [0.3, 0.7, 1.2])
def test_white_phase_error_peak_loss_and_energy(rng, sigma):
    """Independent phase errors of SD sigma: E|h(0)|^2 / |h_0(0)|^2 = exp(-sigma^2) + (1 - exp(-sigma^2)) / N
    (the coherent part and the incoherent sum of N unit phasors), within 5 standard errors; energy is conserved
    exactly in every realisation (Parseval: sum |h|^2 = M N)."""
    phases = sigma * rng.standard_normal((3000, N))
    intensity = compress(phases, None, OS)
    at_zero = intensity[:, intensity.shape[1] // 2] / N ** 2
    expected = math.exp(-sigma ** 2) + (1.0 - math.exp(-sigma ** 2)) / N
    se = at_zero.std(ddof=1) / math.sqrt(at_zero.size)
    assert abs(at_zero.mean() - expected) < 5.0 * se
    np.testing.assert_allclose(intensity.sum(axis=1), N * OS * N, rtol=1e-12)


@pytest.mark.parametrize("a", [1.0, math.pi, 2.0 * math.pi, 9.0])
def test_quadratic_phase_error_peak_loss_and_broadening(a):
    """A residual quadratic phase a u^2 (edge error a / 4) of a linear FM: the peak and 3-dB width of the closed
    form (Fresnel integrals, eq. S10) and the known value 0.80 (-0.97 dB) at an edge error of pi / 2; tolerance
    1e-4 on the peak and 2e-3 on the width (the 128-sample aperture and the width table's interpolation)."""
    u = aperture_grid(256)
    peak, width = ideal_response(256, OS)
    m = irf_metrics(compress((a * u * u)[None], None, OS), OS, peak, width)
    assert 10.0 ** (-m["peak_loss_db"][0] / 10.0) == pytest.approx(defocus_peak(a), abs=1e-4)
    assert m["resolution_ratio"][0] == pytest.approx(float(broadening(a)), abs=2e-3)
    if a == 2.0 * math.pi:
        assert defocus_peak(a) == pytest.approx(0.800, abs=1e-3)


def _screen(c_kl):
    aperture = biomass_aperture(math.radians(28.0))
    return lambda lag: two_way_structure(lag, aperture, c_kl, 2.67, 10e3)


def test_phase_draws_are_those_of_the_full_covariance_bit_for_bit(seed):
    """The structure function is evaluated once per distinct lag of the grid: the draws equal, bit for bit, those
    from the covariance of eq. S9 built lag by lag (the stream of the shipped scenarios is unchanged)."""
    structure = _screen(3e24)
    u = aperture_grid(64)
    d_abs = structure(np.abs(u))
    cov = 0.5 * (d_abs[:, None] + d_abs[None, :] - structure(np.abs(u[:, None] - u[None, :])))
    factor = np.linalg.cholesky(cov + 1e-12 * np.trace(cov) / 64 * np.eye(64))
    expected = np.random.default_rng(seed).standard_normal((5, 64)) @ factor.T
    assert np.array_equal(phase_draws(np.random.default_rng(seed), structure, 64, 5), expected)


@pytest.mark.parametrize("c_kl", [3.6e23, 3e24])
def test_mean_irf_peak_matches_the_closed_form_at_any_strength(rng, c_kl):
    """E|h(0)|^2 of the Monte Carlo against the mean IRF of Belcher & Rogers (2009), eq. S11, exact for a Gaussian
    screen in weak and strong scatter alike: within 5 standard errors of the sample mean."""
    structure = _screen(c_kl)
    intensity = compress(phase_draws(rng, structure, N, 3000), None, OS)
    at_zero = intensity[:, intensity.shape[1] // 2] / N ** 2
    expected = 10.0 ** (-float(analytic_irf(structure, N)["mean_irf_peak_loss_db"]) / 10.0)
    assert abs(at_zero.mean() - expected) < 5.0 * at_zero.std(ddof=1) / math.sqrt(at_zero.size)


def test_monte_carlo_matches_the_weak_scatter_statistics(rng):
    """In weak scatter (E[Y] = 0.07 rad^2) the medians and 90th percentiles of the Monte Carlo agree with eq. S12-S15:
    peak loss and shift within 8 % plus 4 standard errors of a sample quantile (the Marechal law's error is below
    3 % here), 3-dB width ratio within 0.002, ISLR within 0.4 dB (the halo of eq. S15 is partly inside the main
    lobe)."""
    structure = _screen(3.6e23)
    mc = monte_carlo_irf(rng, structure, 4000, N, OS)
    an = analytic_irf(structure, N)
    assert an["weak"]
    for tag in ("median", "p90"):
        for name in ("peak_loss_db", "shift_cells"):
            sample = mc["samples"][name]
            se = 1.2533 * sample.std() / math.sqrt(sample.size) * (1.0 if tag == "median" else 1.5)
            assert abs(mc[f"{name}_{tag}"] - an[f"{name}_{tag}"]) < 0.08 * an[f"{name}_{tag}"] + 4.0 * se, name
        assert mc[f"resolution_ratio_{tag}"] == pytest.approx(float(an[f"resolution_ratio_{tag}"]), abs=2e-3)
        assert mc[f"islr_db_{tag}"] == pytest.approx(float(an[f"islr_db_{tag}"]), abs=0.4)


def test_analytic_path_is_vectorised_over_cases():
    """A block of cases gives, case by case, the numbers each case gets alone (bit for bit)."""
    incidence = np.radians([23.0, 28.0, 33.0])
    c_kl = np.array([1e23, 1e24, 1e25])
    block = analytic_irf(lambda lag: two_way_structure(lag, biomass_aperture(incidence), c_kl, 2.67, 10e3))
    for i in range(3):
        alone = analytic_irf(lambda lag, i=i: two_way_structure(lag, biomass_aperture(incidence[i]), c_kl[i], 2.67,
                                                                10e3))
        for key, value in alone.items():
            assert np.asarray(block[key])[i] == pytest.approx(float(value), rel=1e-12, abs=1e-15), key


@pytest.mark.parametrize("cases", [15, 13])
def test_analytic_path_in_chunks_is_bit_identical(monkeypatch, cases):
    """The matrices go ``CHUNK_CASES`` cases at a time: chunks of 4 (13 cases: the last case joins the chunk before
    it), across the rows of a 2-D case axis too, give, bit for bit, the numbers of the whole block in one chunk (the
    straightforward path); ``quantiles=False`` leaves only the quantile keys out."""
    import e2esim.scintillation.irf_analytic as irf_analytic

    incidence = np.radians(np.linspace(23.0, 33.75, cases))
    c_kl = 10.0 ** np.linspace(22.0, 26.0, cases)

    def run(shape, chunk, quantiles=True):
        monkeypatch.setattr(irf_analytic, "CHUNK_CASES", chunk)
        return analytic_irf(lambda lag: two_way_structure(lag, biomass_aperture(incidence.reshape(shape)),
                                                          c_kl.reshape(shape), 2.67, 10e3), quantiles=quantiles)

    whole = run((cases,), 10 ** 6)
    shapes = [(cases,), (1, cases)] + ([(3, 5)] if cases == 15 else [])
    for shape in shapes:
        chunked, lean = run(shape, 4), run(shape, 4, quantiles=False)
        assert set(lean) == {k for k in whole if not k.endswith(("_median", "_p90"))}
        for key, value in whole.items():
            np.testing.assert_array_equal(chunked[key], value.reshape(shape), err_msg=key, strict=True)
            if key in lean:
                np.testing.assert_array_equal(lean[key], value.reshape(shape), err_msg=key, strict=True)


def test_no_screen_changes_nothing():
    an = analytic_irf(_screen(0.0))
    assert float(an["peak_loss_db_p90"]) == 0.0 and float(an["shift_cells_p90"]) == 0.0
    assert float(an["resolution_ratio_p90"]) == 1.0


@pytest.mark.parametrize("lead", [(), (3,), (2, 5)])
def test_mean_irf_from_the_distinct_lags_is_bit_for_bit_eq_s11_on_the_full_matrix(rng, lead):
    """exp(-D_2 / 2) is taken on the n distinct lags and spread to the n x n matrix: the number is bit for bit eq. S11
    evaluated on the matrix itself (the same elements in the same memory layout, summed in the same order)."""
    incidence = np.radians(rng.uniform(23.0, 34.0, lead))
    c_kl = 10.0 ** rng.uniform(22.5, 25.0, lead)

    def structure(lag):
        return two_way_structure(lag, biomass_aperture(incidence), c_kl, 2.67, 10e3)

    lags = np.abs(np.arange(N)[:, None] - np.arange(N)[None, :])
    d = np.asarray(structure(np.arange(N) / N), dtype=float)[..., lags]
    expected = -10.0 / math.log(10.0) * np.log(np.mean(np.exp(-0.5 * d), axis=(-2, -1)))
    np.testing.assert_array_equal(analytic_irf(structure, N)["mean_irf_peak_loss_db"], expected)


def test_toeplitz_moments_in_reused_arrays_are_the_fancy_index_expressions_bit_for_bit(rng):
    """``_toeplitz_moments`` builds a chunk's matrices in arrays reused across chunks (``_Work``), the mean IRF's in
    the layout of the fancy index x[..., lags] (the case axis innermost), whose order of summation differs from a
    C-contiguous array's: each moment is, bit for bit, that of the expressions on freshly indexed arrays, for chunks
    of 1, 2, 3 and the usual sizes, one ``_Work`` across sizes."""
    import e2esim.scintillation.irf_analytic as irf_analytic

    n = 64
    _, projector, tilt, q = irf_analytic._matrices(n)
    lags = np.abs(np.arange(n)[:, None] - np.arange(n)[None, :])
    work = irf_analytic._Work(n)
    for cases in (32, 33, 1, 2, 3, 32):
        on_lags = np.cumsum(rng.random((cases, n)) ** rng.uniform(0.2, 3.0), axis=1) * 10.0 ** rng.uniform(
            -6.0, 6.0, (cases, 1))
        on_lags[:, 0] = 0.0
        d = on_lags[..., lags]
        pd = projector @ d
        want = np.stack([-np.trace(pd, axis1=-2, axis2=-1) / (2.0 * n),
                         np.einsum("...ij,...ji->...", pd, pd) / (2.0 * n * n),
                         -np.einsum("i,...ij,j->...", tilt, d, tilt) / 2.0,
                         -np.einsum("i,...ij,j->...", q, d, q) / (2.0 * np.dot(q, q) ** 2),
                         np.mean(np.exp(-0.5 * on_lags)[..., lags], axis=(-2, -1))])
        got = irf_analytic._toeplitz_moments(on_lags, lags, projector, tilt, q, work)
        assert got.tobytes() == want.tobytes()
