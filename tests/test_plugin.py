"""A third-party plug-in (examples/e2esim-example-instrument) installed through the entry-point group
``e2esim.modules`` and used by a scenario."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PLUGIN = ROOT / "examples" / "e2esim-example-instrument"


@pytest.fixture(scope="module")
def plugin_path(tmp_path_factory):
    target = tmp_path_factory.mktemp("site")
    proc = subprocess.run(
        [sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--no-build-isolation",
         "--target", str(target), str(PLUGIN)],
        capture_output=True, text=True,
    )
    assert proc.returncode == 0, proc.stderr
    return target


def _e2esim(plugin_path, *args):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(plugin_path), os.environ.get("PYTHONPATH", "")])}
    return subprocess.run([sys.executable, "-m", "e2esim", *args], capture_output=True, text=True, env=env)


def test_plugin_is_listed_with_its_distribution(plugin_path):
    proc = _e2esim(plugin_path, "modules", "instrument", "--json")
    assert proc.returncode == 0, proc.stderr
    records = {r["type"]: r for r in json.loads(proc.stdout)}
    assert records["example_lband"]["distribution"] == "e2esim-example-instrument"
    params = {p["name"]: p for p in records["example_lband"]["parameters"]}
    assert params["calibration_grade"]["default"] == "nominal"
    assert params["centre_frequency_mhz"]["default"] == 1257.0


def test_scenario_using_the_plugin_runs(plugin_path, tmp_path):
    out = tmp_path / "run"
    proc = _e2esim(plugin_path, "run", str(PLUGIN / "scenario.yaml"), "-o", str(out), "--no-progress")
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((out / "summary.json").read_text())
    case = summary["cases"][0]["results"]
    # calibration_grade "degraded" sets crosstalk -25 dB and channel imbalance -30 dB (3-sigma labels)
    assert case["instrument.crosstalk_db"] == -25.0 and case["instrument.channel_imbalance_db"] == -30.0
    assert case["instrument.centre_frequency_hz"] == 1.257e9


def test_plugin_module_conforms(plugin_path):
    code = ("from e2esim.testing import check_module; "
            "from e2esim_example_instrument.instrument import ExampleLBandInstrument as C; "
            "check_module(C, {'calibration_grade': 'excellent'}); print('ok')")
    env = {**os.environ, "PYTHONPATH": str(plugin_path)}
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert proc.returncode == 0 and proc.stdout.strip() == "ok", proc.stderr


def test_without_the_plugin_the_type_is_unknown(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "e2esim", "validate", str(PLUGIN / "scenario.yaml")],
                          capture_output=True, text=True)
    assert proc.returncode == 2 and "unknown instrument type 'example_lband'" in proc.stderr
