"""Straightforward scalar reference of the budget, one case at a time with the ``math`` module.

Written independently of the vectorised kernels (no shared helpers) so that tests can check them against
it and benchmarks/bench_retrieval.py can time them against it. Same equations: Ahmed et al. (2014),
eqs. (20)-(38), with the interpretations documented in ``e2esim.budget``.
"""

from __future__ import annotations

import math

import numpy as np

_C = 299_792_458.0  # m/s


def random_cases(n: int, rng: np.random.Generator, base: dict) -> tuple[dict, dict, np.ndarray]:
    """``n`` random budget cases around ``base`` (a preset), for checking and timing the vectorised budget
    against ``budget_scalar``: returns (base, arrays of varied inputs, sigma0 values in m^2/m^2)."""
    arrays = {
        "bandwidth_hz": rng.uniform(5e6, 100e6, n), "eta_range": rng.uniform(0, 1, n),
        "eta_azimuth": rng.uniform(0, 1, n), "area_m2": rng.uniform(500, 50_000, n),
        "incidence_rad": np.radians(rng.uniform(20, 60, n)), "slope_range_rad": np.radians(rng.uniform(-10, 10, n)),
        "slope_azimuth_rad": np.radians(rng.uniform(-10, 10, n)), "observations": rng.integers(1, 12, n).astype(float),
        "pointing_error_rad": rng.uniform(0, 2e-3, n), "dem_height_error_m": rng.uniform(0, 10, n),
    }
    arrays["diverse_observations"] = np.minimum(rng.integers(1, 4, n), arrays["observations"]).astype(float)
    return dict(base), arrays, rng.uniform(0.005, 0.2, n)


def budget_scalar(case: dict, sigma: float) -> dict:
    """Relative SDs of the named contributions and the total for one case (keys of ``BudgetInputs``,
    scalars, no overrides of eqs. 23-25 and 29 except the resolutions)."""
    dr = case["range_resolution_m"] if case.get("range_resolution_m") else _C / (2 * case["bandwidth_hz"])
    ds = case["azimuth_resolution_m"] if case.get("azimuth_resolution_m") else case["antenna_length_m"] / 2
    kr = 1.6363 - 0.6363 * math.sqrt(case["eta_range"])
    ks = 1.6363 - 0.6363 * math.sqrt(case["eta_azimuth"])
    n = case["area_m2"] * math.sin(case["incidence_rad"]) / (kr * dr * ks * ds)

    def islr(eta):
        return 10 ** ((-46.965 + 104.11 * eta - 112.59 * eta**2 + 43.124 * eta**3) / 10)

    qnr = 10 ** ((2.0 + 6.02 * case["quantisation_bits"]) / 10)
    inv_mnr = islr(case["eta_range"]) + islr(case["eta_azimuth"]) + 10 ** (-case["ambiguity_ratio_db"] / 10) + 1 / qnr
    snr = sigma / case["nesz"] if case["nesz"] > 0 else math.inf
    n_ot, n_os = case["observations"], case["diverse_observations"]
    speckle = 1 / math.sqrt(n * n_os)
    thermal = 1 / math.sqrt(n * n_ot) / snr
    mult = inv_mnr / math.sqrt(n * n_ot)
    k = case["beam_shaping"]
    x = math.pi / (2 * k)
    ln_sinc = math.log(math.sin(x) / x)
    integral = _simpson(lambda t: (math.sin(t) / t) ** 2 if t else 1.0, 0.0, x, 200)  # error ~1e-10
    el = 4 * case["pointing_error_rad"] / case["elevation_beamwidth_rad"] * ln_sinc
    az = 2 * k / math.pi * case["pointing_error_rad"] / case["azimuth_beamwidth_rad"] * ln_sinc / integral
    cal_random = abs(10 ** (case["random_calibration_db"] / 10) - 1) / math.sqrt(n_ot)
    cal_pointing = abs(-2 * (el + az)) / math.sqrt(n_ot)
    factor = math.sqrt(case["dem_posting_m"] ** 2 / (dr * ds) / n)
    dtheta = case["dem_height_error_m"] / case["slant_range_m"]
    cal_dem = factor / math.sqrt(n_os) * abs(4 * dtheta / case["elevation_beamwidth_rad"] * ln_sinc)
    tr, ts, th = case["slope_range_rad"], case["slope_azimuth_rad"], case["incidence_rad"]
    dtau = case["dem_height_error_m"] / (case["dem_posting_m"] * (1 + math.tan(tr) ** 2))
    first = (math.sin(2 * tr) * math.sin(ts) ** 2 + math.sin(2 * ts) * math.sin(tr) ** 2) / (
        2 - 2 * math.sin(tr) ** 2 * math.sin(ts) ** 2)
    second = math.cos(th - tr - ts) / (math.sin(th - tr) * math.cos(ts))
    area = factor / math.sqrt(n_os) * abs((first + second) * dtau)
    temporal = case["temporal_sd_m2m2"] / sigma if case.get("temporal_sd_m2m2") is not None else case[
        "temporal_relative_sd"]
    sn = speckle + thermal + mult
    cal = math.sqrt(cal_random**2 + cal_pointing**2 + cal_dem**2)
    total = math.sqrt(sn**2 + temporal**2 + cal**2 + area**2)
    return {"looks": n, "speckle": speckle, "thermal_noise": thermal, "multiplicative_noise": mult,
            "temporal": temporal, "calibration_random": cal_random, "calibration_pointing": cal_pointing,
            "calibration_dem": cal_dem, "area_projection": area, "total": total}


def _simpson(f, a, b, n):
    h = (b - a) / n
    s = f(a) + f(b)
    for i in range(1, n):
        s += (4 if i % 2 else 2) * f(a + i * h)
    return s * h / 3
