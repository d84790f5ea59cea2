"""Plug-ins that fail while they are imported (issue 22, item 11): one that raises, one that calls sys.exit, one
that hangs. Each is reported naming its distribution and entry point; every command, and every other module,
still works. The plug-ins are fake distributions (a package and its .dist-info folder) on PYTHONPATH."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from e2esim import plugin_import
from e2esim.plugin_import import PluginImportFailed, guarded_import, import_timeout_s

BODIES = {
    "raise": 'raise RuntimeError("boom at import")',
    "exit": "import sys\nsys.exit(3)",
    "hang": "import time\ntime.sleep(600)",
    "not_a_module": "class Bad:\n    pass",
}
PROBLEMS = {
    "raise": "its import raised RuntimeError: boom at import",
    "exit": "it called sys.exit(3) while being imported",
    "hang": "its import did not finish within 1 s (set E2ESIM_PLUGIN_TIMEOUT_S to wait longer)",
    "not_a_module": "entry point 'propagation.bad_not_a_module' of badplug-not-a-module is not an e2esim Module "
                    "subclass",
}
BUILTIN_ONLY = ("scene: {type: table1_forest}\ninstrument: {type: biomass}\n"
                "propagation: [{type: hv_backscatter_error}]\n")


def _plugin(site: Path, how: str) -> Path:
    """A distribution ``badplug-<how>`` with the entry point ``propagation.bad_<how> = badplug_<how>:Bad``."""
    package = site / f"badplug_{how}"
    package.mkdir(parents=True)
    (package / "__init__.py").write_text(BODIES[how] + "\n")
    info = site / f"badplug_{how}-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: badplug-{how.replace('_', '-')}\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(f"[e2esim.modules]\npropagation.bad_{how} = badplug_{how}:Bad\n")
    return site


def _e2esim(site: Path, *args, cwd=None):
    path = os.pathsep.join([str(site), os.environ.get("PYTHONPATH", "")])
    env = {**os.environ, "PYTHONPATH": path, "E2ESIM_PLUGIN_TIMEOUT_S": "1"}
    return subprocess.run([sys.executable, "-m", "e2esim", *args], capture_output=True, text=True, env=env,
                          cwd=cwd, timeout=120)


@pytest.mark.parametrize("how", ["raise", "exit", "hang", "not_a_module"])
def test_a_broken_plugin_is_named_and_every_command_still_works(tmp_path, how):
    """Used to give a traceback (raise), exit silently with status 3 (exit) or hang (hang) in every command, and to
    refuse every command (an entry point that is not a module)."""
    site = _plugin(tmp_path / "site", how)
    warning = (f"e2esim: warning: plug-in badplug-{how.replace('_', '-')}, entry point propagation.bad_{how} = "
               f"badplug_{how}:Bad, is not available: {PROBLEMS[how]}; e2esim goes on without it")
    listing = _e2esim(site, "modules", "propagation")
    assert listing.returncode == 0, listing.stderr
    assert warning in listing.stderr and "Traceback" not in listing.stderr
    assert "propagation.hv_backscatter_error  (e2esim)" in listing.stdout
    assert f"propagation.bad_{how}  (badplug-{how.replace('_', '-')})  NOT AVAILABLE: {PROBLEMS[how]}" in listing.stdout

    (tmp_path / "ok.yaml").write_text(BUILTIN_ONLY)
    valid = _e2esim(site, "validate", "ok.yaml", cwd=tmp_path)
    assert valid.returncode == 0 and "ok.yaml: valid" in valid.stdout and warning in valid.stderr

    (tmp_path / "uses.yaml").write_text(BUILTIN_ONLY.replace("hv_backscatter_error", f"bad_{how}"))
    uses = _e2esim(site, "validate", "uses.yaml", cwd=tmp_path)
    assert uses.returncode == 2, uses.stderr
    assert (f"uses.yaml:3: propagation[0].type: propagation type 'bad_{how}' is registered by the plug-in "
            f"badplug-{how.replace('_', '-')} (propagation.bad_{how} = badplug_{how}:Bad), which could not be "
            f"loaded: {PROBLEMS[how]}") in uses.stderr


@pytest.mark.parametrize("how", ["raise", "exit", "hang"])
def test_a_class_path_whose_import_fails_is_a_clear_error(tmp_path, how):
    """``type: package.module:Class`` of a package the scenario allows (``plugins:``) is imported the same way."""
    site = _plugin(tmp_path / "site", how)
    (tmp_path / "s.yaml").write_text(f"plugins: [badplug_{how}]\n"
                                     + BUILTIN_ONLY.replace("hv_backscatter_error", f"'badplug_{how}:Bad'"))
    for folder in site.glob("*.dist-info"):  # not an installed distribution: only the plugins: list allows it
        for item in folder.iterdir():
            item.unlink()
        folder.rmdir()
    proc = _e2esim(site, "validate", "s.yaml", cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    assert f"propagation[0].type: cannot import 'badplug_{how}:Bad': {PROBLEMS[how]}" in proc.stderr


def test_guarded_import_returns_the_value_and_reports_every_failure():
    assert guarded_import(lambda: 42, 5.0) == 42

    def exits():
        raise SystemExit("bye")

    with pytest.raises(PluginImportFailed, match=r"it called sys.exit\('bye'\) while being imported") as info:
        guarded_import(exits, 5.0)
    assert isinstance(info.value.__cause__, SystemExit)

    def raises():
        raise ImportError("No module named 'x'")

    with pytest.raises(PluginImportFailed, match=r"its import raised ImportError: No module named 'x'"):
        guarded_import(raises, 5.0)


def test_the_import_timeout_is_10_s_unless_set(monkeypatch):
    monkeypatch.delenv(plugin_import.TIMEOUT_VARIABLE, raising=False)
    assert import_timeout_s() == plugin_import.PLUGIN_IMPORT_TIMEOUT_S == 10.0
    for bad in ("", "soon", "-1", "0", "inf", "nan"):
        monkeypatch.setenv(plugin_import.TIMEOUT_VARIABLE, bad)
        assert import_timeout_s() == 10.0
    monkeypatch.setenv(plugin_import.TIMEOUT_VARIABLE, "60")
    assert import_timeout_s() == 60.0
