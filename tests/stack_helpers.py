"""Shared multi-pass test cases (tests/test_stack_*.py and benchmarks/bench_stack.py)."""

from __future__ import annotations

import numpy as np

from e2esim.faraday.distribution import GaussianFaraday
from e2esim.instrument.system_errors import SystemErrorModel
from e2esim.scene.covariance import ScatteringCovariance
from e2esim.scene.table1 import TABLE1_FORESTS
from e2esim.stack.acquisitions import preset_stack
from e2esim.stack.faraday import StackFaraday
from e2esim.stack.scene import StackScene
from e2esim.stack.sites import SITE_FORESTS, SITES
from e2esim.stack.system import StackSystemErrors
from e2esim.stack.temporal import TemporalDecorrelation


def table1(name: str) -> ScatteringCovariance:
    biome, agb, hh, hv, vv, r, theta = TABLE1_FORESTS[name]
    return ScatteringCovariance.from_powers(hh, hv, vv, r, np.radians(theta), agb_t_ha=agb, biome=biome, label=name)


def site_scene(site: str = "boreal", phase: str = "interferometric", temporal: TemporalDecorrelation | None = None):
    """The StackScene of a site preset at 28.4 deg incidence."""
    return StackScene(preset_stack(phase, np.radians(28.375)), table1(SITE_FORESTS[site]), SITES[site],
                      temporal or TemporalDecorrelation())


def rich_system(crosstalk=1e-3, imbalance=2e-3, noise_db=-27.0, gain_sd_db=0.2) -> SystemErrorModel:
    """Unequal variances, complex pair correlations and a gain error: every term of the kernel is exercised."""
    return SystemErrorModel(crosstalk_level=crosstalk, imbalance_level=imbalance, crosstalk_relative=(1, 1.2, 0.8, 1.1),
                            crosstalk_rho13=0.3, crosstalk_rho24=-0.2 + 0.1j, imbalance_relative=(1.0, 0.7),
                            imbalance_rho=0.4 + 0.2j, noise_power=10 ** (noise_db / 10), gain_offset_db=0.05,
                            gain_sd_db=gain_sd_db)


BOREAL_FR = GaussianFaraday(np.radians(60.0), np.radians(5.0))
"""Men et al. (2021), Fig. 1: boreal Faraday rotation, mean 60 deg, SD 5 deg."""


def stack_errors(system=None, correlation=1.0, difference_deg=0.0, faraday=BOREAL_FR):
    return (StackSystemErrors(system if system is not None else rich_system(), correlation),
            StackFaraday(faraday, np.radians(difference_deg)))


def ground_cancelled_with_faraday_correction(channels="all", looks=(20, 100_000), mode="analytic"):
    """scenarios/biomass_ground_cancelled.yaml (3 passes, boreal, dawn) with a calibration section of one
    faraday_correction step whose estimation window is swept; a constant Faraday rotation of 20 deg, the same on
    every pass (the climatology's nodes make a case slower, not different)."""
    import yaml

    from quick_runs import SCENARIOS

    raw = yaml.safe_load((SCENARIOS / "biomass_ground_cancelled.yaml").read_text())
    raw["ionosphere"] = {"type": "constant_faraday", "value_deg": 20.0}  # few nodes: a fast case
    raw["propagation"][0]["faraday_difference_sd_deg"] = 0.0
    raw["propagation"][0].pop("tec_correlation", None)  # the differences are stated: it would change nothing
    raw["calibration"] = [{"type": "faraday_correction"}]
    raw["propagation"][0]["channels"] = channels
    raw["retrieval"] = {"type": "stack_multichannel_power_law" if channels == "all" else "stack_power_law"}
    raw["requirements"] = raw["requirements"][1:]  # the AGB RMSE (no attribution: it needs no variant without a source)
    raw["simulation"].update(mode=mode, realisations=400)
    raw["sweep"] = {"mode": "grid", "parameters": {"calibration.0.looks": list(looks)}}
    raw.pop("output")
    return raw
