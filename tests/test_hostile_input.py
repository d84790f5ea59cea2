"""Hostile input (issue 15): every bad scenario, override or file ends in exit status 2 with one line naming
the file, the key path, the value and what is allowed, within seconds, and never runs code from a file.

Categories: size, depth, aliases, tags, types, paths, permissions, encodings, out-of-range numbers, NaN and
infinity, overrides of swept keys, and module imports. Everything runs in this process (``cli.main``)
except the few checks that need a fresh interpreter (the current directory on ``sys.path``, a pipe).
"""

import os
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest
from test_scenario_errors import GOOD

from e2esim.cli import main
from e2esim.errors import ConfigError, LimitError
from e2esim.runner.scenario import Scenario

ROOT = Path(__file__).resolve().parents[1]
LIMIT_S = 60.0
"""A hang guard, not a speed check (timings are not asserted in tests): what these inputs provoke unchecked (an alias
bomb expanded, 3.6e9 dates built, a 1e9-value sweep) takes many minutes or exhausts memory, while a refusal takes
well under a second; 60 s tells the two apart on a loaded machine, where 10 s failed."""


def _validate(tmp_path, capsys, text, *extra, name="scenario.yaml"):
    path = tmp_path / name
    if isinstance(text, bytes):
        path.write_bytes(text)
    elif text is not None:
        path.write_text(text, encoding="utf-8")
    start = time.monotonic()
    status = main(["validate", str(path), *extra])
    elapsed = time.monotonic() - start
    out, err = capsys.readouterr()
    if status == 2:
        assert err.startswith("e2esim: error: ") and err.count("\n") == 1, repr(err)
    return status, err, out, elapsed


def _refused(tmp_path, capsys, text, *extra, expect=()):
    status, err, _, elapsed = _validate(tmp_path, capsys, text, *extra)
    assert status == 2, err
    assert elapsed < LIMIT_S
    for part in expect:
        assert part in err, (part, err)
    return err


# ---------------------------------------------------------------------------------------------- size
def test_oversized_file(tmp_path, capsys):
    _refused(tmp_path, capsys, GOOD + "description: " + "x" * 1_100_000 + "\n",
             expect=["larger than the limit of 1,000,000 bytes"])


def test_dev_zero_as_scenario(capsys):
    start = time.monotonic()
    status = main(["validate", "/dev/zero"])
    err = capsys.readouterr().err
    assert status == 2 and "/dev/zero: the scenario file is larger than the limit" in err
    assert time.monotonic() - start < LIMIT_S


@pytest.mark.parametrize("sweep, expect", [
    ("  parameters:\n" + "".join(f"    instrument.{k}: {{linspace: [-40, -20, 100]}}\n" for k in
                                 ("crosstalk.level_db", "channel_imbalance.level_db", "nesz_db"))
     + "    instrument.gain_sd_db: [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0]\n",
     ["sweep.parameters: 10,000,000 sweep cases exceed the limit of 5,000,000", "split the sweep", "--workers"]),
    ("  parameters:\n    instrument.nesz_db: {linspace: [-40, -20, 1e9]}\n",
     ["sweep.parameters.instrument.nesz_db.linspace: 1,000,000,000 sweep values exceed the limit of 5,000,000"]),
    ("  parameters:\n    instrument.nesz_db: {logspace: [1, 2, 1e300]}\n", ["1e+300 sweep values exceed the limit"]),
])
def test_huge_sweeps(tmp_path, capsys, sweep, expect):
    _refused(tmp_path, capsys, GOOD + "sweep:\n" + sweep, expect=expect)


def test_monte_carlo_memory(tmp_path, capsys):
    _refused(tmp_path, capsys, GOOD.replace("mode: analytic", "mode: both\n  realisations: 1e11"),
             expect=["simulation: the Monte Carlo of looks=100000, realisations=1e+11", "TiB per case",
                     "above the limit of 4 GiB", "use mode: analytic"])


ORBIT = GOOD + textwrap.dedent("""\
    orbit:
      type: biomass_orbit
      site: {lat_deg: 60, lon_deg: 10}
      acquisitions: {start: "2026-01-01", end: "2026-12-31", step_days: STEP}
""")


def test_acquisition_dates(tmp_path, capsys):
    _refused(tmp_path, capsys, ORBIT.replace("STEP", "1e-7"),
             expect=["orbit.acquisitions.step_days: 3,640,000,001 dates", "exceed the limit of 100,000 dates"])
    _refused(tmp_path, capsys, ORBIT.replace("STEP", "1e300"),
             expect=["orbit.acquisitions.step_days: 1e+300 is out of range", "<= 36525 day"])  # no overflow
    status, err, _, elapsed = _validate(tmp_path, capsys, ORBIT.replace("STEP", "36525"))
    assert status == 0 and elapsed < LIMIT_S, err  # a step beyond the period: the first date only


# ---------------------------------------------------------------------------------------------- depth
@pytest.mark.parametrize("nest", ["[" * 5000 + "]" * 5000, "{a: " * 5000 + "1" + "}" * 5000])
def test_deep_nesting(tmp_path, capsys, nest):
    _refused(tmp_path, capsys, GOOD + f"description: {nest}\n",
             expect=["nested deeper than the limit of 100 levels"])


def test_deep_nesting_through_python_and_overrides(tmp_path, capsys):
    deep = current = {}
    for _ in range(5000):
        current["a"] = {}
        current = current["a"]
    with pytest.raises(LimitError, match="nested deeper than the limit of 100 levels"):
        Scenario({"scene": {"type": "table1_forest"}, "instrument": {"type": "biomass"}, "description": deep}).resolve()
    _refused(tmp_path, capsys, GOOD, "--set", "description=" + "[" * 5000 + "]" * 5000,
             expect=["--set description", "nested deeper"])


# ---------------------------------------------------------------------------------------------- aliases
LAUGHS = "".join(f"x{i}: &x{i} [" + ", ".join([f"*x{i - 1}"] * 9) + "]\n" for i in range(1, 10))


@pytest.mark.parametrize("where", ["top", "sweep.cases"])
def test_billion_laughs(tmp_path, capsys, where):
    if where == "top":
        text = "x0: &x0 [lol]\n" + LAUGHS + GOOD
    else:
        bomb = "".join(f"  - &c{i} {{instrument.nesz_db: [" + ", ".join([f"*c{i - 1}"] * 9) + "]}\n"
                       for i in range(1, 10))
        text = GOOD + "sweep:\n  cases:\n  - &c0 {instrument.nesz_db: -30}\n" + bomb
    _refused(tmp_path, capsys, text, expect=["more than the limit of 100,000 values", "aliases"])


def test_recursive_alias(tmp_path, capsys):
    _refused(tmp_path, capsys, GOOD + "description: &a [1, *a]\n",
             expect=["refers to a mapping or list that contains it"])


MERGED = GOOD.replace("  - type: agb_error_bound\n", """\
  - &strict {type: agb_error_bound, bound_percent: 10, side: over}
  - <<: [*strict, {name: loose, bound_percent: 5}]
    bound_percent: 30
""")


def test_merge_keys_are_supported(tmp_path, capsys):
    status, err, _, _ = _validate(tmp_path, capsys, MERGED)
    assert status == 0, err
    reqs = [m for m in Scenario.load(tmp_path / "scenario.yaml").resolve().cases[0].modules if m.kind == "requirement"]
    assert [(r.config["bound_percent"], r.config["side"], r.config["name"]) for r in reqs] == [
        (10.0, "over", None), (30.0, "over", "loose")]  # its own key wins, then the first merged mapping
    _refused(tmp_path, capsys, GOOD + "output:\n  <<: [1, 2]\n", expect=["a merge key (<<) needs a mapping"])


# ---------------------------------------------------------------------------------------------- tags
@pytest.mark.parametrize("tag", ["!!python/name:os.system", "!!python/object/apply:os.system ['touch MARKER']",
                                 "!!binary aGVsbG8=", "!custom x", "!!set {a}", "!!timestamp 2026-01-01"])
def test_tags_that_build_objects_are_refused(tmp_path, capsys, monkeypatch, tag):
    monkeypatch.chdir(tmp_path)
    err = _refused(tmp_path, capsys, GOOD + f"description: {tag}\n", expect=["is not allowed", "plain data"])
    assert ":13:" in err and not (tmp_path / "MARKER").exists()


def test_standard_tags_are_plain_data(tmp_path, capsys):
    status, err, _, _ = _validate(tmp_path, capsys, GOOD + "description: !!str 5\n")
    assert status == 0, err
    _refused(tmp_path, capsys, GOOD + "description: !!int abc\n", expect=[":13: cannot read the value 'abc'"])


# ---------------------------------------------------------------------------------------------- types
def test_integer_key_in_a_swept_section(tmp_path, capsys):
    text = (GOOD.replace("  crosstalk:\n", "  1: 2\n  crosstalk:\n")
            + "sweep:\n  parameters:\n    instrument.nesz_db: [-30, -27]\n")
    _refused(tmp_path, capsys, text, expect=[":7: the key '1' in instrument is read as int 1", "quote it"])
    _refused(tmp_path, capsys, GOOD + "output: {yes: 1}\n", expect=["is read as bool True", "keys must be text"])
    with pytest.raises(ConfigError, match=r"instrument\[1\]: the key 1 is int, not text; keys must be text"):
        Scenario({"scene": {"type": "table1_forest"}, "instrument": {"type": "biomass", 1: 2},
                  "sweep": {"parameters": {"instrument.nesz_db": [-30, -27]}}}).resolve()


@pytest.mark.parametrize("value, expect", [
    (":", "':' is not a class path; expected package.module:ClassName"),
    (".foo:X", "'.foo:X' is not a class path"),
    ("a b:C", "'a b:C' is not a class path"),
    ("this:x", "will not import 'this' for 'this:x': 'this' is not an installed distribution"),
    ("os:system", "will not import 'os'"),
    ("numpy:ndarray", "'numpy:ndarray' is not an e2esim Module subclass"),
    ("e2esim.scene.modules:Table1ForestScene", "is a scene module, not a instrument module"),
])
def test_class_paths(tmp_path, capsys, value, expect):
    err = _refused(tmp_path, capsys, GOOD.replace("type: biomass", f"type: '{value}'"),
                   expect=["instrument.type", expect])
    assert "Beautiful is better than ugly" not in err + capsys.readouterr().out  # `import this` never ran


EVIL = "from pathlib import Path\nPath(__file__).with_name('MARKER').write_text('pwned')\nclass X: pass\n"


@pytest.mark.parametrize("on_path", ["", "cwd"])
def test_a_module_in_the_working_directory_never_runs(tmp_path, capsys, monkeypatch, on_path):
    """``python -m e2esim`` puts the working directory first on sys.path (and '' means it too); the lookup
    ignores it, even when the package is allowed explicitly."""
    (tmp_path / "evil.py").write_text(EVIL)
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(on_path or str(tmp_path))
    text = GOOD.replace("type: biomass", "type: 'evil:X'")
    _refused(tmp_path, capsys, text, expect=["'evil' is not an installed distribution"])
    _refused(tmp_path, capsys, text, "--allow-import", "evil",
             expect=["cannot import 'evil:X': No module named 'evil'"])
    assert not (tmp_path / "MARKER").exists() and "evil" not in sys.modules


PLUGIN = textwrap.dedent("""\
    from pathlib import Path
    from e2esim.instrument.modules import BiomassInstrument
    Path(__file__).parent.parent.joinpath("IMPORTED").write_text("yes")

    class MyRadar(BiomassInstrument):
        type_name = "my_radar"
""")


def test_plugins_list_and_allow_import(tmp_path, capsys, monkeypatch):
    site = tmp_path / "site"
    (site / "trusted_radars").mkdir(parents=True)
    (site / "trusted_radars" / "__init__.py").write_text("")
    (site / "trusted_radars" / "radar.py").write_text(PLUGIN)
    monkeypatch.syspath_prepend(str(site))
    text = GOOD.replace("type: biomass", "type: trusted_radars.radar:MyRadar")
    _refused(tmp_path, capsys, text, expect=["plugins: [trusted_radars]", "--allow-import trusted_radars"])
    assert not (tmp_path / "IMPORTED").exists()
    status, err, out, _ = _validate(tmp_path, capsys, text, "--allow-import", "trusted_radars")
    assert status == 0 and "instrument=my_radar" in out, err
    status, err, out, _ = _validate(tmp_path, capsys, "plugins: [trusted_radars.radar]\n" + text)
    assert status == 0, err
    _refused(tmp_path, capsys, "plugins: [../x]\n" + text, expect=["plugins[0]", "is not a Python package name"])


# ---------------------------------------------------------------------------------------------- paths
def test_paths(tmp_path, capsys):
    (tmp_path / "loop1").symlink_to(tmp_path / "loop2")
    (tmp_path / "loop2").symlink_to(tmp_path / "loop1")
    (tmp_path / "broken.yaml").symlink_to(tmp_path / "nowhere.yaml")
    for path, expect in [(tmp_path / "loop1", "is a symbolic link loop"),
                         (tmp_path / "broken.yaml", "is a broken symbolic link"),
                         (tmp_path / "missing.yaml", "no such scenario file"),
                         (tmp_path, "is a folder, not a scenario file"),
                         (tmp_path / ("x" * 300), "the file name is too long")]:
        assert main(["validate", str(path)]) == 2
        err = capsys.readouterr().err
        assert expect in err and err.count("\n") == 1, err


SAMPLES = GOOD + "ionosphere: {type: faraday_samples, samples_file: FILE}\n"


@pytest.mark.parametrize("make, expect", [
    (lambda p: np.save(p / "s.npy", np.ones((3, 4))), "holds a 2-D array of shape (3, 4)"),
    (lambda p: (p / "s.txt").write_text("1 2\n3 4\n"), "holds a 2-D array of shape (2, 2)"),
    (lambda p: (p / "s.txt").write_text("root:x:0:0:secret-first-line:/root:/bin/bash\n"),
     "is not a text file of numbers"),
    (lambda p: (p / "s.txt").write_text("1\nnan\n"), "holds 1 values that are NaN or infinite"),
    (lambda p: (p / "s.txt").write_text("# only a comment\n"), "holds no samples"),
    (lambda p: (p / "s.txt").symlink_to(p / "s.txt"), "is a symbolic link loop"),
    (lambda p: (p / "s.txt").mkdir(), "is a folder"),
])
def test_samples_files(tmp_path, capsys, make, expect):
    make(tmp_path)
    name = "s.npy" if (tmp_path / "s.npy").exists() else "s.txt"
    err = _refused(tmp_path, capsys, SAMPLES.replace("FILE", name), expect=["ionosphere.samples_file", expect])
    assert "secret-first-line" not in err and "root:x" not in err  # the content is never echoed


def test_pickled_samples_never_run(tmp_path, capsys):
    from test_journal_plain import Payload

    np.save(tmp_path / "s.npy", np.array([Payload(tmp_path / "MARKER")], dtype=object), allow_pickle=True)
    _refused(tmp_path, capsys, SAMPLES.replace("FILE", "s.npy"), expect=["holds Python objects, which are not read"])
    assert not (tmp_path / "MARKER").exists()


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="permissions do not bind root")
def test_unreadable_scenario(tmp_path, capsys):
    path = tmp_path / "s.yaml"
    path.write_text(GOOD)
    path.chmod(0)
    assert main(["validate", str(path)]) == 2
    assert "cannot read the scenario file: Permission denied" in capsys.readouterr().err


def test_unreadable_scenario_simulated(tmp_path, capsys, monkeypatch):
    import builtins

    path = tmp_path / "s.yaml"
    path.write_text(GOOD)
    real_open = builtins.open

    def denied(file, *args, **kwargs):
        if str(file) == str(path):
            raise PermissionError(13, "Permission denied")
        return real_open(file, *args, **kwargs)

    monkeypatch.setattr(builtins, "open", denied)
    assert main(["validate", str(path)]) == 2
    assert "cannot read the scenario file: Permission denied" in capsys.readouterr().err


# ---------------------------------------------------------------------------------------------- encodings
@pytest.mark.parametrize("data, expect", [
    (b"name: t\nscene: \xff\xfe\n", "it is not UTF-8 text (byte 0xff at offset 15)"),
    (GOOD.encode("utf-16"), "it is not UTF-8 text"),
    (GOOD.encode() + b"description: a\x00b\n", "malformed YAML"),
    (GOOD.encode() + b"description: \x1b[31mred\n", "malformed YAML"),
])
def test_encodings(tmp_path, capsys, data, expect):
    _refused(tmp_path, capsys, data, expect=[expect])


def test_utf8_bom_and_unicode_are_fine(tmp_path, capsys):
    status, err, _, _ = _validate(tmp_path, capsys, "\ufeff" + GOOD.replace("name: t", "name: forêt_ünïcode"))
    assert status == 0, err


# ---------------------------------------------------------------------------------------------- numbers
@pytest.mark.parametrize("value, expect", [
    ("5.0", "5 is out of range; expected a number with -200 <= value <= 0 dB"),
    (".nan", "nan is not a finite number"),
    (".inf", "inf is not a finite number"),
    ("-.inf", "-inf is not a finite number"),
    ("1e400", "inf is not a finite number"),
    ("1" * 400, "an integer of 400 digits is too large"),
    ("1" * 5000, "cannot read the value"),
    ("0x1p3", "has the wrong type"),
    ("[-30]", "[-30] has the wrong type; expected a number"),
])
def test_out_of_range_numbers(tmp_path, capsys, value, expect):
    _refused(tmp_path, capsys, GOOD.replace("level_db: -30", f"level_db: {value}"), expect=[expect])


def test_out_of_range_numbers_via_set(tmp_path, capsys):
    for value, expect in [("999", "999 is out of range"), (".nan", "nan is not a finite number"),
                          ("1e999", "inf is not a finite number")]:
        _refused(tmp_path, capsys, GOOD, "--set", f"instrument.nesz_db={value}",
                 expect=["instrument.nesz_db", expect])


# ---------------------------------------------------------------------------------------------- overrides
DEFAULT = ROOT / "scenarios" / "biomass_default.yaml"


def test_set_on_a_swept_key_is_an_error(capsys):
    for value in ("999", "10"):  # out of range, or valid: both would be silently replaced by the sweep
        assert main(["validate", str(DEFAULT), "--set", f"orbit.site.lat_deg={value}"]) == 2
        err = capsys.readouterr().err
        assert "orbit.site.lat_deg: the sweep sets orbit.site.lat_deg in its cases (sweep.cases)" in err
        assert "--replace-sweep orbit.site.lat_deg=VALUE" in err and err.count("\n") == 1
    assert main(["validate", str(DEFAULT), "--set", "orbit.site={lat_deg: 5, lon_deg: 1}"]) == 2
    assert "orbit.site: the sweep sets orbit.site.name" in capsys.readouterr().err  # a section holding swept keys


def _module(case, kind: str):
    return next(m for m in case.modules if m.kind == kind)


def test_sweep_values_can_be_changed(capsys):
    assert main(["validate", str(DEFAULT), "--set", "sweep.cases.0.orbit.site.lat_deg=999"]) == 2
    err = capsys.readouterr().err
    assert "orbit.site.lat_deg: 999 is out of range" in err and "sweep case 0" in err
    assert main(["validate", str(DEFAULT), "--replace-sweep", "orbit.site.lat_deg=999"]) == 2
    assert "orbit.site.lat_deg: 999 is out of range" in capsys.readouterr().err
    sc = Scenario.load(DEFAULT, replace_sweep=["orbit.site.lat_deg=45"]).resolve()
    assert len(sc.cases) == 5 and all("orbit.site.lat_deg" not in c.inputs for c in sc.cases)
    assert {_module(c, "orbit").config["site"]["lat_deg"] for c in sc.cases} == {45.0}


def test_replace_sweep_and_set_sweep_parameters(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text(GOOD + "sweep:\n  parameters:\n    'instrument.nesz_db, scene.forest': [[-30, boreal_50], "
                           "[-27, boreal_200]]\n    instrument.gain_sd_db: [0.1, 0.2]\n")
    sc = Scenario.load(path, ["sweep.parameters.instrument.gain_sd_db=[0.1, 0.2, 0.3]"]).resolve()
    assert len(sc.cases) == 6
    sc = Scenario.load(path, replace_sweep=["instrument.nesz_db=-25"]).resolve()
    assert [c.inputs for c in sc.cases][:2] == [{"scene.forest": "boreal_50", "instrument.gain_sd_db": 0.1},
                                                {"scene.forest": "boreal_50", "instrument.gain_sd_db": 0.2}]
    assert {_module(c, "instrument").config["nesz_db"] for c in sc.cases} == {-25.0}
    with pytest.raises(ConfigError, match=r"--replace-sweep instrument\.bandwidth_mhz: the sweep does not set"):
        Scenario.load(path, replace_sweep=["instrument.bandwidth_mhz=5"])


def test_validate_and_run_apply_overrides_alike(tmp_path, capsys):
    path = tmp_path / "s.yaml"
    path.write_text(GOOD)
    for command in (["validate"], ["run", "-o", str(tmp_path / "out")]):
        assert main([command[0], str(path), *command[1:], "--set", "instrument.nesz_db=999"]) == 2
        assert "instrument.nesz_db: 999 is out of range" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


# ---------------------------------------------------------------------------------------------- messages
def test_physics_errors_name_the_full_key_path(tmp_path, capsys):
    text = ORBIT.replace("STEP", "15").replace('start: "2026-01-01"', 'start: "2027-01-01"')
    _refused(tmp_path, capsys, text, expect=["orbit.acquisitions.end: period end 2026-12-31 is before its start"])
    _refused(tmp_path, capsys, ORBIT.replace("STEP", "15").replace('"2026-01-01"', '"1st of May"'),
             expect=["orbit.acquisitions.start: '1st of May' is not an ISO date"])
    _refused(tmp_path, capsys, ORBIT.replace("STEP", "15") + "  incidence_near_deg: 40\n",
             expect=["orbit.incidence_near_deg: 40 is not below incidence_far_deg"])


def test_every_message_is_one_line(capsys, monkeypatch):
    from e2esim import cli
    from e2esim.errors import UserError

    def raises(args):
        raise UserError("first line\n  second line\n")

    monkeypatch.setitem(cli.COMMANDS, "validate", raises)
    assert main(["validate", "x.yaml"]) == 2
    assert capsys.readouterr().err == "e2esim: error: first line second line\n"


def test_long_values_are_cut_in_messages(tmp_path, capsys):
    err = _refused(tmp_path, capsys, GOOD.replace("forest: boreal_200", "forest: " + "y" * 5000))
    assert len(err) < 600 and "yyyy..." in err


def test_broken_pipe_exits_quietly(monkeypatch, capsys):
    """``e2esim modules | head -1``: the reader goes away; e2esim stops quietly with status 0."""
    read, write = os.pipe()
    os.close(read)
    stdout = os.fdopen(write, "w", buffering=1)
    monkeypatch.setattr(sys, "stdout", stdout)
    try:
        status = main(["modules"])
    finally:
        stdout.close()
    assert status == 0 and capsys.readouterr().err == ""


# ---------------------------------------------------------------------------------------------- seed
def test_seed_of_64_bits_or_more_is_refused_at_validation(tmp_path, capsys):
    # issue 22 item 4: a seed of 2^64 passed validate; every case ran, then results.h5 could not store it
    # ("Object dtype has no native HDF5 equivalent"), leaving a stray plot; --resume crashed the same way
    path = tmp_path / "scenario.yaml"
    path.write_text(GOOD, encoding="utf-8")
    for seed in (2**64, 10**30):
        status = main(["validate", str(path), "--set", f"simulation.seed={seed}"])
        err = capsys.readouterr().err
        assert status == 2 and err.count("\n") == 1, err
        assert f"simulation.seed: {seed} is out of range" in err
        assert "expected an integer with 0 <= value <= 18446744073709551615" in err
    out = tmp_path / "out"
    status = main(["run", str(path), "-o", str(out), "--no-progress", "--set", f"simulation.seed={2**64 - 1}"])
    assert status == 0, capsys.readouterr().err
    import h5py

    with h5py.File(out / "results.h5", "r") as f:
        assert int(f.attrs["seed"]) == 2**64 - 1
