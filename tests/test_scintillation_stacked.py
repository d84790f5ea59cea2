"""The scintillation screens and mixture quantiles vectorised over the cases of a block (issue 24, Speed;
``e2esim.scintillation.stacked``) give each case, bit for bit, the numbers of the scalar per-case kernels
(``acquisition_screens``, ``mixture_quantiles``), over many random inputs."""

from __future__ import annotations

from dataclasses import fields, replace

import numpy as np
import pytest

from e2esim.errors import PhysicsInputError
from e2esim.scintillation.acquisitions import AcquisitionScreens, ScreenSettings, acquisition_screens, mixture_quantiles
from e2esim.scintillation.cell import cell_acquisitions
from e2esim.scintillation.stacked import (
    bisect_rows,
    stacked_halo_shares,
    stacked_mixture_quantiles,
    stacked_screens,
    stacked_weighted_sums,
)


def _same(a, b) -> bool:
    """Bit for bit (NaN where NaN)."""
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def _random_cells(rng, n: int) -> tuple:
    geometries = [cell_acquisitions(float(rng.uniform(-89.0, 89.0)), float(rng.uniform(-180.0, 180.0)),
                                    int(rng.integers(1, 13)), str(rng.choice(["dawn", "dusk"])))
                  for _ in range(n)]
    # two solar levels and a fixed strength: the cases of a block fall into several groups
    choices = (ScreenSettings(sunspot_number=10.0), ScreenSettings(sunspot_number=150.0, percentile=90.0),
               ScreenSettings(c_kl=10.0 ** 24.0))
    settings = [choices[int(k)] for k in rng.integers(0, len(choices), n)]
    return geometries, settings


@pytest.mark.parametrize("site", [(None, None), (-0.54, 2.03)])
def test_stacked_screens_are_bit_for_bit_each_case_alone(rng, site):
    geometries, settings = _random_cells(rng, 20)
    stacked = stacked_screens(geometries, settings, *site)
    for g, s, got in zip(geometries, settings, stacked):
        alone = acquisition_screens(g, s, *site)
        for f in fields(AcquisitionScreens):
            assert _same(getattr(got, f.name), getattr(alone, f.name)), f.name
    assert len({id(s) for s in stacked}) == len(stacked)
    for cells in (1.5, 24.1):
        for got, s in zip(stacked_halo_shares(stacked, cells), stacked):
            assert _same(got, s.halo_share(cells))
    names = ("magnetic_latitude", "log10_ckl", "weak", "mean_irf_peak_loss_db")
    for got, s in zip(stacked_weighted_sums(stacked, names), stacked):  # the output scalars' weighted sums
        assert all(_same(got[name], np.sum(s.weight * getattr(s, name))) for name in names)


def _random_screens(rng, n: int) -> AcquisitionScreens:
    """Screens with random weights and laws; some acquisitions without irregularities (theta = 0, SD = 0)."""
    def some_zero(x):
        return np.where(rng.random(n) < 0.2, 0.0, x)

    weight = rng.random(n) + 0.01
    zero = np.zeros(n)
    return AcquisitionScreens(weight / weight.sum(), zero, zero, zero, shape=rng.uniform(0.05, 20.0, n),
                              scale=some_zero(10.0 ** rng.uniform(-4.0, 0.5, n)),
                              shift_sd_cells=some_zero(10.0 ** rng.uniform(-3.0, 0.3, n)),
                              quadratic_sd_rad=some_zero(10.0 ** rng.uniform(-2.0, 1.0, n)),
                              mean_irf_peak_loss_db=zero, weak=zero > 0.0, scan_length_m=rng.uniform(1e3, 5e3, n))


@pytest.mark.parametrize("prob", [0.5, 0.9, 0.137])
def test_stacked_mixture_quantiles_are_bit_for_bit_the_scalar_bisection(rng, prob):
    screens = [_random_screens(rng, int(n)) for n in rng.choice([1, 3, 7, 40], size=60)]
    screens.append(replace(screens[0], scale=np.zeros_like(screens[0].scale),
                           shift_sd_cells=np.zeros_like(screens[0].scale)))  # no irregularities at all
    for got, s in zip(stacked_mixture_quantiles(screens, prob), screens):
        want = mixture_quantiles(s, prob)
        assert got.keys() == want.keys()
        for key in want:
            assert _same(got[key], want[key]), key


def test_the_row_bisection_finds_each_rows_root():
    roots = np.array([0.1, 2.5, 7.0])
    found = bisect_rows(lambda x: x / roots, 1.0, np.full(3, 10.0))
    np.testing.assert_allclose(found, roots, rtol=1e-14)


def test_a_bad_screen_in_a_stack_is_refused_with_the_key():
    geometries, _ = _random_cells(np.random.default_rng(0), 2)
    with pytest.raises(PhysicsInputError, match="spectral index") as err:
        stacked_screens(geometries, [ScreenSettings(spectral_index=5.5)] * 2)
    assert err.value.key == "spectral_index"


CHAIN = {
    "name": "scintillation_in_blocks",
    "scene": {"type": "table1_forest", "forest": "tropical_338"},
    "instrument": {"type": "biomass"},
    "ionosphere": {"type": "gaussian_faraday", "mean_deg": 5.0, "sd_deg": 5.0},
    "propagation": [{"type": "hv_backscatter_error"},
                    {"type": "backscatter_error_budget", "preset": "biomass_200m"}],
    "retrieval": {"type": "power_law"},
    "error_terms": [{"type": "scintillation_sigma0", "lat_deg": 65.0, "lon_deg": 20.0, "month": 3},
                    {"type": "scintillation_calibration", "lat_deg": 65.0, "lon_deg": 20.0, "month": 3}],
    "requirements": [{"type": "agb_rmse", "sources": "computed", "max_percent": 40}],
    "simulation": {"mode": "analytic", "seed": 3, "looks": 2000},
    # the screens differ between the cases of a block: latitude and the solar level (two stacked groups)
    "sweep": {"mode": "grid", "parameters": {"error_terms.0.lat_deg, error_terms.1.lat_deg": [[8.0, 8.0],
                                                                                              [70.0, 70.0]],
                                             "error_terms.0.solar, error_terms.1.solar": [["min", "min"],
                                                                                          ["max", "max"]]}},
}


def test_the_scintillation_terms_in_a_block_give_the_per_case_engines_numbers():
    import copy
    import math

    from e2esim.error_terms.block_wrapped import BlockWrappedModel
    from e2esim.runner.blocks import BlockRun
    from e2esim.runner.run import default_services, run_block, run_scenario
    from e2esim.runner.scenario import Scenario

    resolved = Scenario(copy.deepcopy(CHAIN), "chain.yaml").resolve()
    n = len(resolved.cases)
    assert n == 4
    model = BlockRun(resolved.plan, np.arange(n), default_services()).run()["backscatter.error"]
    assert isinstance(model, BlockWrappedModel) and model.sources[-2:] == ("scintillation_sigma0",
                                                                           "scintillation_calibration")
    per_case = run_scenario(resolved, progress=False, engine="per_case")
    block = run_block(resolved, np.arange(n))
    for k, index in enumerate(block.indices):
        got, want = block.case(k, {}, ""), per_case.cases[int(index)]
        assert list(got.scalars) == list(want.scalars)
        for name, value in want.scalars.items():
            assert got.scalars[name] == value or (math.isnan(value) and math.isnan(got.scalars[name])), name
        assert [(v.passed, v.value) for v in got.verdicts] == [(v.passed, v.value) for v in want.verdicts]
