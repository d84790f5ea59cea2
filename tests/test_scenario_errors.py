"""Every user error of a scenario ends with exit status 2 and a message naming the file and key path
(issue "Foundation", Build item 8), never a traceback."""

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from e2esim.cli import main
from quick_runs import quick_overrides

GOOD = textwrap.dedent("""\
    name: t
    scene:
      type: table1_forest
      forest: boreal_200
    instrument:
      type: biomass
      crosstalk:
        level_db: -30
    requirements:
      - type: agb_error_bound
    simulation:
      mode: analytic
""")


def _validate(tmp_path, text, capsys, *extra):
    path = tmp_path / "scenario.yaml"
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text)
    status = main(["validate", str(path), *extra])
    err = capsys.readouterr().err
    return status, err, str(path)


def test_good_scenario_validates(tmp_path, capsys):
    status, err, _ = _validate(tmp_path, GOOD, capsys)
    assert status == 0, err


CASES = {
    "empty file": ("  \n", ["the scenario file is empty"]),
    "malformed yaml": ("scene: [unclosed\n", ["malformed YAML", "line"]),
    "duplicate key": (GOOD + "scene:\n  type: table1_forest\n", ["duplicate key 'scene'"]),
    "unknown section": (GOOD + "instrumnet: {}\n", ["instrumnet", "unknown key", "did you mean 'instrument'"]),
    "unknown key": (GOOD.replace("level_db: -30", "levl_db: -30"),
                    ["instrument.crosstalk.levl_db", "unknown key 'levl_db'", "did you mean 'level_db'", ":8:"]),
    "wrong type": (GOOD.replace("level_db: -30", "level_db: minus thirty"),
                   ["instrument.crosstalk.level_db", "'minus thirty' has the wrong type", "expected a number"]),
    "out of range": (GOOD.replace("level_db: -30", "level_db: 5.0"),
                     ["instrument.crosstalk.level_db", "5 is out of range", "<= 0 dB"]),
    "bad choice": (GOOD.replace("forest: boreal_200", "forest: boreal_2000"),
                   ["scene.forest", "'boreal_2000' is not allowed", "did you mean 'boreal_200'", "boreal_350"]),
    "unknown module type": (GOOD.replace("type: biomass", "type: biomas"),
                            ["instrument.type", "unknown instrument type 'biomas'", "biomass", "gaussian_errors"]),
    "missing section": (GOOD.replace("instrument:", "instrument_x:"), ["unknown key 'instrument_x'"]),
    "missing required section": ("scene: {type: table1_forest}\n", ["instrument: section is missing"]),
    "missing type": (GOOD.replace("  type: table1_forest\n", ""), ["scene.type", "is required", "table1_forest"]),
    "sweep over missing key": (GOOD + "sweep:\n  parameters:\n    instrument.crosstalk.levl_db: [-30, -28]\n",
                               ["instrument.crosstalk.levl_db", "unknown key 'levl_db'", "sweep case 0"]),
    "sweep over missing parameter of a module": (
        GOOD + "sweep:\n  parameters:\n    scene.agb_t_ha: [100, 200]\n",
        ["scene.agb_t_ha", "unknown key 'agb_t_ha'", "valid keys here: forest"]),
    "bad sweep value list": (GOOD + "sweep:\n  parameters:\n    scene.forest: boreal_50\n",
                             ["sweep.parameters.scene.forest", "is not a list of values"]),
    "bad value in a sweep case": (GOOD + "sweep:\n  parameters:\n    instrument.nesz_db: [-27, 30]\n",
                                  ["instrument.nesz_db", "30 is out of range", "sweep case 1"]),
    "sweep over an item of a section the scenario lacks": (  # found by the fuzz test (a StopIteration before)
        GOOD.replace("requirements:\n  - type: agb_error_bound\n", "")
        + "sweep:\n  parameters:\n    requirements.0.side: [over, under]\n",
        ["sweep.requirements.0.side", "sets an item of 'requirements' that the scenario does not have",
         "the scenario has no requirements"]),
    "requirements not a list": (GOOD.replace("  - type: agb_error_bound", "  type: agb_error_bound"),
                                ["requirements", "is not a list"]),
    "bad simulation mode": (GOOD.replace("mode: analytic", "mode: fast"),
                            ["simulation.mode", "'fast' is not allowed", "'analytic', 'montecarlo', 'both'"]),
    "impossible covariance": (GOOD.replace("  type: table1_forest\n  forest: boreal_200\n",
                                           "  type: covariance\n  hhvv_magnitude: 5.0\n"),
                              ["scene", "not positive semi-definite"]),
    "not a mapping": ("- just\n- a list\n", ["must be a mapping of sections"]),
    "invalid utf-8": (b"scene: \xff\xfe\n", ["cannot read the scenario file"]),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_user_errors_exit_2_with_a_message(tmp_path, capsys, name):
    text, fragments = CASES[name]
    status, err, path = _validate(tmp_path, text, capsys)
    assert status == 2
    assert err.startswith("e2esim: error: ")
    assert path in err
    for fragment in fragments:
        assert fragment in err, f"{fragment!r} not in {err!r}"
    assert "Traceback" not in err


def test_missing_file(tmp_path, capsys):
    status = main(["validate", str(tmp_path / "nope.yaml")])
    err = capsys.readouterr().err
    assert status == 2 and "nope.yaml: no such scenario file" in err


def test_folder_instead_of_file(tmp_path, capsys):
    status = main(["validate", str(tmp_path)])
    assert status == 2 and "is a folder, not a scenario file" in capsys.readouterr().err


def test_bad_set_override(tmp_path, capsys):
    status, err, _ = _validate(tmp_path, GOOD, capsys, "--set", "instrument.nesz_db=loud")
    assert status == 2 and "instrument.nesz_db" in err and "--set instrument.nesz_db" in err
    status, err, _ = _validate(tmp_path, GOOD, capsys, "--set", "nonsense")
    assert status == 2 and "is not key=value" in err
    status, err, _ = _validate(tmp_path, GOOD, capsys, "--set", "instrument.crosstalk.level_db=-28")
    assert status == 0


def test_no_traceback_in_a_real_process_and_debug_shows_it(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text(GOOD.replace("level_db: -30", "level_db: 5.0"))
    proc = subprocess.run([sys.executable, "-m", "e2esim", "validate", str(path)], capture_output=True, text=True)
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr and "instrument.crosstalk.level_db" in proc.stderr
    proc = subprocess.run([sys.executable, "-m", "e2esim", "--debug", "validate", str(path)], capture_output=True,
                          text=True)
    assert proc.returncode != 0 and "Traceback" in proc.stderr


LARGE = ("biomass_global_map",)
"""Scenarios validated at their quick size (tests/quick_runs.py)."""


def test_every_scenario_in_the_repository_validates(capsys):
    root = Path(__file__).resolve().parents[1] / "scenarios"
    files = sorted(root.glob("*.yaml"))
    assert files
    for path in files:
        # the global map's 200 000 cases take minutes to resolve case by case: its quick size here
        sets = [a for o in quick_overrides(path.stem) for a in ("--set", o)] if path.stem in LARGE else []
        assert main(["validate", str(path), *sets]) == 0, capsys.readouterr().err
