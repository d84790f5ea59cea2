"""Real orbits drive the default scenario (state-vector files and TLEs), and bad orbit files are refused with exit
status 2, one clear line naming the file, the element and what is allowed, and no output folder."""

from __future__ import annotations

import datetime as dt

import numpy as np
import pytest
import yaml
from orbit_files import circular_trajectory, eocfi_text, tle_lines, write_nisar_orbit

from e2esim.cli import main
from e2esim.orbit.geometry import view_geometry
from e2esim.orbit.real.tle import gmst
from e2esim.orbit.real_modules import BiomassOrbitFile
from e2esim.orbit.sunsync import SunSynchronousOrbit, keplerian_period, sun_synchronous_inclination
from e2esim.runner.run import run_scenario
from e2esim.runner.scenario import Scenario
from quick_runs import SCENARIOS, quick_overrides

REAL = SCENARIOS / "biomass_default_real_orbit.yaml"
BIOMASS = SunSynchronousOrbit(666e3, 6.0, "left")
EPOCH_JD = 2461161.5  # 2026-05-01 00:00 UTC
SIBERIA = {"name": "siberia", "lat_deg": 60.0, "lon_deg": 92.0}


def biomass_tle(mean_anomaly_deg: float) -> tuple:
    """A BIOMASS-like element set at 2026-05-01 00:00 UTC: 666 km sun-synchronous, RAAN = GMST + 90 deg at the
    epoch, so the ascending node is at 06:00 local mean solar time (LTAN = UT + (RAAN - GMST) / 15 deg/h)."""
    revs = 86400.0 / float(keplerian_period(666e3))
    raan = (np.degrees(gmst(EPOCH_JD)) + 90.0) % 360.0
    return tle_lines(dt.datetime(2026, 5, 1), np.degrees(sun_synchronous_inclination(666e3)), raan, 1e-4, 90.0,
                     mean_anomaly_deg, revs)


def test_state_vector_files_drive_the_default_scenario(quick_run):
    """The shipped scenario: biomass_default's five cases, each site's one pass from its EO CFI file."""
    result, folder = quick_run("biomass_default_real_orbit")
    assert len(result.cases) == 5 and (folder / "results.h5").is_file()
    geometries = [c.products["geometry"] for c in result.cases]
    assert [g.size for g in geometries] == [1] * 5 and geometries[3].site.name == "paracou_guiana"
    incidence = [float(np.degrees(g.incidence[0])) for g in geometries]
    # the files' passes (28, 25, 31 deg on the mean sphere; test_orbit_real checks those to 1e-6 rad) seen from the
    # WGS84 ellipsoid, 9.0 km inside the sphere at 60 deg N (lower incidence) and 7 km outside it at the equator
    np.testing.assert_allclose(np.array(incidence)[[0, 3, 4]], [27.615, 25.226, 31.278], atol=1e-3)
    assert [g.pass_label[0] for g in geometries] == ["dawn"] * 3 + ["dusk", "dawn"]


def test_a_tle_drives_the_default_scenario(tmp_path):
    """Each site's pass from a TLE (the same orbit plane, a different along-track phase per site: the orbit images
    a site only where its swath reaches it), the chain of biomass_default after it."""
    scenario = yaml.safe_load(REAL.read_text())
    phase = {"central_siberia": 60.0, "paracou_guiana": 30.0, "lope_gabon": 0.0}
    for case in scenario["sweep"]["cases"]:
        name = f"{case['orbit.site.name']}.tle"
        (tmp_path / name).write_text("\n".join(biomass_tle(phase[case["orbit.site.name"]])) + "\n")
        case["orbit.file"] = name
    path = tmp_path / "tle.yaml"
    path.write_text(yaml.safe_dump(scenario))
    scenario = Scenario.load(path, quick_overrides("biomass_default_real_orbit"))
    results = run_scenario(scenario.resolve(), progress=False, command="TLE-driven default scenario")
    assert len(results.cases) == 5
    geometries = [c.products["geometry"] for c in results.cases]
    assert [g.size for g in geometries] == [1] * 5 and all(g.pass_label[0] == "dawn" for g in geometries)
    # each site seen once in the 3 days after the epoch, inside the swath (23-33.75 deg; values of this element set)
    incidence = [np.degrees(g.incidence[0]) for g in geometries[2:]]
    np.testing.assert_allclose(incidence, [28.967, 26.867, 28.842], atol=1e-3)


def test_tle_geometry_is_that_of_its_orbit_plane():
    """The TLE's pass over the site matches the circular orbit of the TLE's own plane (inclination and LTAN of the
    osculating elements) at the same incidence: local time to 1e-3 h (3.6 s) and heading to 0.01 deg, the size of
    SGP4's short-period terms and the 1e-4 eccentricity over a 330 km slant range. The LTAN is the 06:00 the element
    set's RAAN implies (GMST + 90 deg), to 0.002 h (the osculating node differs from the mean one)."""
    module = BiomassOrbitFile(file=str(SCENARIOS / "orbits" / "biomass_like.tle"), surface="sphere", site=SIBERIA)
    g = module.geometry
    assert g.size == 1 and g.pass_label[0] == "dawn"
    assert module.orbit.ltan_h == pytest.approx(6.0, abs=0.002)
    view = view_geometry(module.orbit, np.radians(60.0), np.radians(92.0), g.incidence[0], "ascending")
    assert g.local_time_h[0] == pytest.approx(float(view.local_time_h), abs=1e-3)
    assert np.degrees(g.heading[0]) == pytest.approx(np.degrees(float(view.heading)), abs=0.01)


@pytest.fixture(scope="module")
def pass_vectors():
    return circular_trajectory(BIOMASS, 60.0, 92.0, 28.0, "ascending")


def _bad(tmp_path, capsys, file, *sets):
    scenario = yaml.safe_load(REAL.read_text())
    del scenario["sweep"]
    scenario["orbit"]["file"] = str(file)
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(scenario))
    out = tmp_path / "out"
    args = [a for s in (*quick_overrides("biomass_default_real_orbit"), *sets) for a in ("--set", s)]
    assert main(["run", str(path), "-o", str(out), "--no-progress", *args]) == 2
    err = capsys.readouterr().err
    assert err.startswith("e2esim: error: ") and err.count("\n") == 1 and "Traceback" not in err
    assert not out.exists()  # no partial output
    return err


def test_truncated_state_vector_file(tmp_path, capsys, pass_vectors):
    text = eocfi_text(*pass_vectors[:3])
    (tmp_path / "cut.EOF").write_text(text[: len(text) // 2])
    err = _bad(tmp_path, capsys, tmp_path / "cut.EOF")
    assert "cut.EOF: not a complete XML document" in err and "orbit.file" in err


def test_state_vectors_in_wrong_units(tmp_path, capsys, pass_vectors):
    times, r, v, _ = pass_vectors
    (tmp_path / "km.EOF").write_text(eocfi_text(times, r / 1e3, v / 1e3, position_unit="km"))
    err = _bad(tmp_path, capsys, tmp_path / "km.EOF")
    assert "Data_Block/List_of_OSVs/OSV[0]/X has unit='km'; expected unit=\"m\"" in err


def test_an_orbit_that_does_not_cover_the_acquisition_time(tmp_path, capsys, pass_vectors):
    (tmp_path / "orbit.EOF").write_text(eocfi_text(*pass_vectors[:3]))
    err = _bad(tmp_path, capsys, tmp_path / "orbit.EOF", "orbit.start='2026-06-01T00:00:00'")
    assert "orbit.start" in err and "2026-06-01T00:00:00 UTC is outside the orbit's span, 2026-04-30T22:01" in err


def test_a_tle_with_a_bad_checksum(tmp_path, capsys):
    l1, l2 = biomass_tle(60.0)
    good = l2[-1]
    l2 = l2[:-1] + str((int(good) + 1) % 10)
    (tmp_path / "bad.tle").write_text(f"{l1}\n{l2}\n")
    err = _bad(tmp_path, capsys, tmp_path / "bad.tle")
    assert f"bad.tle: TLE line 2 has checksum '{l2[-1]}', but its columns 1-68 sum to {good} (mod 10)" in err


@pytest.mark.parametrize("damage, message", [
    ("no_position", "/science/LSAR/GCOV/metadata/orbit/position is missing"),
    ("kilometres", "/science/LSAR/GCOV/metadata/orbit/position has units 'kilometers'; expected one of 'meters'"),
    ("epoch", "/science/LSAR/GCOV/metadata/orbit/time has units 'seconds'; expected \"seconds since"),
    ("truncated", "not an HDF5 file"),
    ("half", "product.h5: not an HDF5 file, or a damaged one (a truncated download?)"),
])
def test_bad_nisar_orbit_groups(tmp_path, capsys, pass_vectors, damage, message):
    import h5py

    times, r, v, _ = pass_vectors
    path = tmp_path / "product.h5"
    write_nisar_orbit(path, times, r, v, position_units="kilometers" if damage == "kilometres" else "meters",
                      time_units="seconds" if damage == "epoch" else None)
    if damage == "no_position":
        with h5py.File(path, "a") as f:
            del f["/science/LSAR/GCOV/metadata/orbit/position"]
    if damage in ("truncated", "half"):
        data = path.read_bytes()
        path.write_bytes(data[:4] if damage == "truncated" else data[: len(data) // 2])
    assert message in _bad(tmp_path, capsys, path)


@pytest.mark.parametrize("name, what", [("orbit.EOF", "EO CFI orbit file"), ("orbit", "orbit file")])
def test_a_fifo_is_refused_not_waited_on(tmp_path, capsys, name, what):
    import os

    os.mkfifo(tmp_path / name)
    assert f"{name}: the {what} is a FIFO (named pipe), not a regular file" in _bad(tmp_path, capsys, tmp_path / name)


def test_dawn_and_dusk_passes_come_from_the_orbit_plane():
    """The file's pass over central Siberia is ascending, at dawn (LTAN 06:00): asking for dusk leaves none."""
    path = SCENARIOS / "orbits" / "biomass_circular_siberia.EOF"
    assert BiomassOrbitFile(file=str(path), passes="dawn", site=SIBERIA).geometry.pass_name.tolist() == ["ascending"]
    with pytest.raises(Exception, match=r"does not image site siberia .* 1 on a pass not asked for"):
        BiomassOrbitFile(file=str(path), passes="dusk", site=SIBERIA)


def test_a_tle_without_the_orbits_extra(tmp_path, capsys, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "sgp4.api", None)
    err = _bad(tmp_path, capsys, SCENARIOS / "orbits" / "biomass_like.tle")
    assert "needs the optional extra 'orbits' (sgp4.api is not installed): pip install 'e2esim[orbits]'" in err
