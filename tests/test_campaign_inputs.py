"""Bad inputs of the calibration campaign exit 2 with a message naming the file, the key path, the value and what
is allowed (issue 25, Done when), and a user's sites file is read."""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

from e2esim.campaign.site_file import read_sites_file
from e2esim.campaign.sites import PRESETS
from e2esim.cli import main
from e2esim.errors import PhysicsInputError
from quick_runs import SCENARIOS

SCENARIO = SCENARIOS / "biomass_calibration_campaign.yaml"


def _scenario(tmp_path, **campaign):
    raw = yaml.safe_load(SCENARIO.read_text())
    raw["calibration"][0].update(campaign)
    raw["sweep"]["parameters"] = {"calibration.0.epoch_day": [10.0]}
    path = tmp_path / "campaign.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    return path


def test_a_negative_drift_variance_exits_2_naming_file_key_value_and_bound(tmp_path, capsys):
    path = _scenario(tmp_path, drift_crosstalk={"random_walk_variance_per_day": -1e-6})
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    assert "campaign.yaml" in err and "calibration[0].drift_crosstalk.random_walk_variance_per_day" in err
    assert "-1e-06 must be a finite number >= 0" in err


def test_a_schedule_longer_than_the_mission_exits_2(tmp_path, capsys):
    path = _scenario(tmp_path, mission_years=3.0, schedule_years=4.0)
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    assert "calibration[0].schedule_years" in err
    assert "a schedule of 4 years is longer than the mission (3 years); allowed: at most mission_years" in err


def test_a_site_never_seen_exits_2_naming_the_site_and_its_file(tmp_path, capsys):
    (tmp_path / "sites.yaml").write_text(yaml.safe_dump({"sites": [
        {"name": "north_pole_reflector", "lat_deg": 89.5, "lon_deg": 0.0, "type": "corner_reflector",
         "calibrates": ["gain"], "snr_db": 30.0, "scr_db": 25.0}]}))
    path = _scenario(tmp_path, sites_file="sites.yaml", sites=["new_norcia_transponder"], mission_years=0.2,
                     search_max_per_year=0)
    assert main(["run", str(path), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "campaign.yaml" in err and "calibration[0]" in err
    assert "site north_pole_reflector (89.50, 0.00 deg) is never seen in 73.05 days" in err
    assert "of the sites file sites.yaml" in err


def test_a_sites_file_under_home_is_the_file_read_and_the_file_hashed(tmp_path, monkeypatch, capsys):
    # "~" expands as for every input file (e2esim.input_files.scenario_relative), so provenance hashes the file read
    home = tmp_path / "home"
    home.mkdir()
    monkeypatch.setenv("HOME", str(home))
    (home / "sites.yaml").write_text(yaml.safe_dump({"sites": [
        {"name": "north_pole_reflector", "lat_deg": 89.5, "lon_deg": 0.0, "type": "corner_reflector",
         "calibrates": ["gain"], "snr_db": 30.0, "scr_db": 25.0}]}))
    path = _scenario(tmp_path, sites_file="~/sites.yaml", sites=["new_norcia_transponder"], mission_years=0.2,
                     search_max_per_year=0)
    assert main(["run", str(path), "-o", str(tmp_path / "out")]) == 2
    assert "site north_pole_reflector (89.50, 0.00 deg) is never seen" in capsys.readouterr().err


def test_a_sites_file_is_read_and_its_bad_entries_named(tmp_path):
    good = tmp_path / "good.yaml"
    good.write_text(yaml.safe_dump({"sites": [
        {"name": "my_reflector", "lat_deg": -20.0, "lon_deg": 190.0, "type": "corner_reflector",
         "calibrates": ["gain", "imbalance"], "snr_db": 35.0, "scr_db": 28.0, "stability_percent": 2.0}]}))
    (site,) = read_sites_file(good, key="sites_file")
    assert site.name == "my_reflector" and site.lon == pytest.approx(math.radians(-170.0))
    assert site.stability == pytest.approx(0.02) and site.calibrates == ("gain", "imbalance")
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump({"sites": [{"name": "x", "lat_deg": 0.0, "lon_deg": 0.0, "type": "lake",
                                              "calibrates": ["gain"], "snr_db": 1.0}]}))
    with pytest.raises(PhysicsInputError, match=r"bad.yaml: sites.0.type: site x: type 'lake' is not one of "
                                                r"transponder, corner_reflector, distributed, point_scatterers"):
        read_sites_file(bad, key="sites_file")


def test_presets_state_a_source_for_their_values_and_leave_out_the_amazon():
    assert not any("amazon" in name for name in PRESETS)
    selima = PRESETS["selima_sand_sheet"]
    assert selima.snr_db == pytest.approx(-23.0 - (-27.0))  # Quegan et al. 2018, Section 4
    assert "crosstalk" not in selima.calibrates and set(PRESETS["new_norcia_transponder"].calibrates) == {
        "gain", "crosstalk", "imbalance"}
    assert all(site.sources for site in PRESETS.values())
    assert np.degrees(PRESETS["dome_c"].lat) == pytest.approx(-75.1)


def test_no_target_of_opportunity_is_stated_by_the_empty_list(tmp_path, capsys):
    # issue 25: `opportunity: []` means "no target of opportunity" (the framework refused empty lists before)
    path = _scenario(tmp_path, opportunity=[], mission_years=0.3, search_max_per_year=0)
    assert main(["validate", str(path)]) == 0
    from e2esim.campaign.modules import Campaign

    given = {k: v for k, v in yaml.safe_load(path.read_text())["calibration"][0].items() if k != "type"}
    assert Campaign(**given).config["opportunity"] == ()


def test_the_frequency_is_stated_taken_from_the_instrument_or_reported_as_assumed():
    """Without an instrument module and a stated frequency_mhz, BIOMASS's 435 MHz is used and flagged as assumed
    (the summary's frequency_assumed); the instrument's frequency otherwise, or the campaign's own."""
    from types import SimpleNamespace

    from e2esim.campaign.modules import Campaign

    def frequency(stated, instrument):
        return Campaign.frequency_hz(SimpleNamespace(config={"frequency_mhz": stated}), instrument)

    nisar = SimpleNamespace(centre_frequency_hz=1.257e9)
    assert frequency(None, None) == (435e6, True)
    assert frequency(None, nisar) == (1.257e9, False)
    assert frequency(440.0, nisar) == (440e6, False)


def test_a_repeat_cycle_no_orbit_can_keep_exits_2_naming_the_key(tmp_path, capsys):
    path = _scenario(tmp_path, repeat_days=0.05, mission_years=0.2, search_max_per_year=0)
    assert main(["run", str(path), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "campaign.yaml" in err and "calibration[0].repeat_days" in err
    assert "no sun-synchronous orbit between 200 and 3000 km repeats after 1 revolutions in 0.05 days" in err


def test_a_second_run_of_the_same_campaign_reuses_its_outcome(tmp_path, monkeypatch):
    """`e2esim run` and its chain schedule search run the same campaign twice in one process, each run handed the
    process's memo: the campaign is computed once; any other setting or orbit computes it again, and only the last
    campaign is kept."""
    from types import SimpleNamespace

    from e2esim.campaign import modules
    from e2esim.case import KernelMemo

    path = _scenario(tmp_path, mission_years=0.3)
    given = {k: v for k, v in yaml.safe_load(path.read_text())["calibration"][0].items() if k != "type"}
    computed = []
    memo = KernelMemo()  # the process's memo: every run of the process is handed it
    monkeypatch.setattr(modules, "compute_outcome", lambda module, setup, assumed: computed.append(setup) or object())
    monkeypatch.setattr(modules.Campaign, "setup_for", lambda self, orbit, frequency: (orbit, frequency))

    class Case(dict):
        def __init__(self, orbit):
            super().__init__(geometry=SimpleNamespace(orbit=orbit))
            self.services = SimpleNamespace(memo=memo)  # a new run: the same process memo

    campaign = modules.Campaign(**given)
    first = campaign.outcome(Case("orbit A"))
    assert campaign.outcome(Case("orbit A")) is first and len(computed) == 1
    assert modules.Campaign(**{**given, "epoch_day": 70.0}).outcome(Case("orbit A")) is first
    assert modules.Campaign(**{**given, "transponder_per_year": 1}).outcome(Case("orbit A")) is not first
    assert campaign.outcome(Case("orbit B")) is not first and len(computed) == 3
    assert campaign.outcome(Case("orbit A")) is not first and len(computed) == 4  # one campaign kept (bounded)
