"""scenarios/biomass_fr_climatology.yaml: BIOMASS with Faraday rotation from the IRI/IGRF climatology for a
boreal and a tropical site, dawn and dusk, solar minimum and maximum, reporting the AGB error of each case."""

from pathlib import Path

import numpy as np
import pytest

from e2esim.faraday.climatology import FaradayClimatology
from e2esim.runner.run import run_scenario
from e2esim.runner.scenario import Scenario

SCENARIO = Path(__file__).resolve().parents[1] / "scenarios" / "biomass_fr_climatology.yaml"


def _check(result):
    assert len(result.cases) == 8
    by = {}
    for c in result.cases:
        fr = c.get("faraday.geophysical")
        assert isinstance(fr, FaradayClimatology)
        label = c.inputs["orbit.passes"]
        assert set(fr.pass_label) == {label}
        for key in ("agb.analytic.q99865_percent", "agb.montecarlo.q99865_percent", "agb.analytic.rmse_percent"):
            assert np.isfinite(c.scalars[key])
        by[(c.inputs["orbit.site.name"], label, c.inputs["ionosphere.solar"])] = fr
    for site, sign in (("boreal_siberia", 1), ("tropical_lope", -1)):  # B.k > 0 north of the dip equator
        for p in ("dawn", "dusk"):
            lo, hi = by[(site, p, "min")], by[(site, p, "max")]
            assert np.sign(lo.mean_rad) == sign
            assert abs(hi.mean_rad) > abs(lo.mean_rad)  # more electrons at solar maximum
    return by


def test_fr_climatology_scenario_fast(quick_run):
    result, folder = quick_run("biomass_fr_climatology")
    _check(result)
    assert (folder / "faraday_distributions.png").exists()


@pytest.mark.slow
def test_fr_climatology_scenario_as_shipped(tmp_path):
    sc = Scenario.load(SCENARIO, overrides=(f"ionosphere.cache_dir={tmp_path / 'cache'}",))
    by = _check(run_scenario(sc.resolve(), progress=False))
    # dusk at solar maximum over the boreal site: tens of degrees one way at 435 MHz
    assert np.degrees(by[("boreal_siberia", "dusk", "max")].mean_rad) > 20
