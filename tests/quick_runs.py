"""Every shipped scenario at reduced sizes, run once per test session (``quick_run`` fixture, tests/conftest.py).

The default suite runs each scenario once through these overrides (smaller Monte Carlo, sparser dates,
fewer swath positions and variability nodes, a coarse global map); tests that need a scenario's results
share that run. The full sizes run in the tests marked slow (tests/test_scenarios_run.py).
"""

from __future__ import annotations

import os
from pathlib import Path

SCENARIOS = Path(__file__).resolve().parents[1] / "scenarios"

_MC = ("simulation.realisations=400", "simulation.looks=2000")
_ORBIT = ("orbit.acquisitions.step_days=60", "orbit.swath_samples=2", "ionosphere.variability_nodes=3")
_REGRESSION = ("simulation.realisations=500", "retrieval.regression.bootstrap_samples=30",
               "retrieval.regression.simex_samples=5")

_STACK = ("simulation.realisations=300", "simulation.looks=2000", "orbit.acquisitions.step_days=120",
          "orbit.swath_samples=2", "ionosphere.variability_nodes=3", "requirements.0.level_margins=false",
          "requirements.0.curve_points=5")

QUICK = {
    "biomass_calibration": ("simulation.realisations=600", "simulation.looks=20000"),
    "biomass_default": (*_MC, *_ORBIT),
    "biomass_default_real_orbit": (*_MC, "ionosphere.variability_nodes=3"),  # one pass per site: nothing to thin
    "biomass_default_from_product": _MC,  # one acquisition per case (the product's): nothing to thin
    "biomass_error_budget": _REGRESSION,
    "biomass_ground_cancelled": (*_STACK, "propagation.0.tec_variability=0"),
    "biomass_ground_cancelled_tomographic": (*_STACK, "propagation.0.faraday_difference_sd_deg=0"),
    "biomass_fr_climatology": ("orbit.acquisitions.step_days=120", "orbit.swath_samples=2",
                               "ionosphere.method=thin_shell", "ionosphere.variability_nodes=3",
                               "simulation.realisations=300", "simulation.looks=1000"),
    "biomass_latitude_sweep": ("orbit.acquisitions.step_days=120", "orbit.swath_samples=2",
                               "ionosphere.variability_nodes=2", "ionosphere.global_map_step_deg=30"),
    "biomass_global_map": ("sweep.map.step_deg=10", "ionosphere.grid_step_deg=10", "sweep.map.months=[1,7]",
                           "sweep.map.lat_range_deg=[-30,70]", "sweep.map.lon_range_deg=[-20,60]",
                           "ionosphere.table_lat_range_deg=[-30,70]", "ionosphere.table_lon_range_deg=[-20,60]",
                           "requirements.0.max_percent=29",  # a region at 10 deg; a limit the boreal cells fail
                           "sweep.map.not_acquired=none"),  # its boreal cells are European: test_acquisition_mask
    "biomass_global_map_scintillation_rfi": ("sweep.map.months=[1]", "sweep.map.lat_range_deg=[60,70]",
                                             "sweep.map.lon_range_deg=[90,110]",
                                             "ionosphere.table_lat_range_deg=[60,70]",
                                             "ionosphere.table_lon_range_deg=[90,110]"),  # Siberia: high latitude
    "biomass_multichannel": (*_MC, "requirements.0.curve_points=9"),
    "biomass_scintillation": ("simulation.realisations=200", "simulation.looks=2000",
                              "orbit.acquisitions.step_days=120", "orbit.swath_samples=1",
                              "ionosphere.variability_nodes=2",
                              "sweep.parameters.orbit.passes=[dusk]"),
    "biomass_rfi": ("sweep.parameters.error_terms.0.band_fraction_percent=[0,20]",),  # the ends of the range
    "nisar_lband": ("simulation.realisations=200", "simulation.looks=2000", "orbit.acquisitions.step_days=120",
                    "orbit.swath_samples=2", "ionosphere.variability_nodes=2"),
    "uavsar_ahmed2014": _REGRESSION,
    "biomass_fr_requirement": ("orbit.acquisitions.step_days=120", "orbit.swath_samples=2",
                               "ionosphere.variability_nodes=3", "sweep.parameters.orbit.passes=[dawn]",
                               "output.answer=false"),
    # ^ its bias x SD boundary costs a dozen engine runs of ~1.4 s CPU each even at the smallest sizes (2 bias
    # values, 1 date, 1 swath position): the answer's code is tested on small chains (tests/test_run_answer.py,
    # test_solve_speed.py); the full answer runs in test_scenarios_run.py (slow)
    "biomass_allocation": ("output.answer=false",),  # two analytic cases; the answer: tests/test_run_answer.py
    "biomass_calibration_campaign": ("calibration.0.step_days=5", "calibration.0.search_max_per_year=2",
                                     "sweep.parameters.calibration.0.epoch_day=[91,1826]"),
}
"""Overrides (``--set``) of each scenario for the default suite; others get ``_MC``."""


def quick_overrides(name: str) -> tuple:
    return QUICK.get(name, _MC)


def scenario_names() -> list:
    return sorted(p.stem for p in SCENARIOS.glob("*.yaml"))


GROUP = {name: "b" for name in ("uavsar_ahmed2014", "biomass_ground_cancelled_tomographic", "nisar_lband",
                                 "biomass_ground_cancelled", "biomass_fr_requirement", "biomass_scintillation",
                                 "biomass_global_map_scintillation_rfi", "men2021_tradeoff_under", "men2021_fig2")}
"""The second of the two groups of quick runs (the others form the first, biomass_default's), chosen so that both
take about as long: about 47 s and 49 s on one quiet core, measured as the time of each scenario's quick run and of
the tests reading it (pytest --junitxml, suite on two cores). pytest-xdist runs each group on one worker
(tests/conftest.py); a test reading several quick runs needs them in one group (tests/test_quick_run_groups.py)."""


def quick_run_group(names: list) -> str:
    """The pytest-xdist group of a test that reads the quick runs of ``names``: the group of the first."""
    if os.environ.get("E2ESIM_TEST_GROUP_PER_SCENARIO"):  # measuring the cost of each scenario's group
        return f"quick_runs_{names[0] if names else 'other'}"
    return f"quick_runs_{GROUP.get(names[0], 'a') if names else 'a'}"
