"""Every scenario in scenarios/ runs from the command line and produces its plots (reduced Monte Carlo
sizes keep this quick; the full sizes run in `make demo` and by hand)."""

from pathlib import Path

import pytest

from e2esim.cli import main

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = sorted((ROOT / "scenarios").glob("*.yaml"))
QUICK = ["--set", "simulation.realisations=400", "--set", "simulation.looks=2000"]
EXTRA = {  # the global Faraday-rotation maps (a whole-globe climatology) are slow: drawn by docs/theory/ionosphere_figures.py
    "biomass_latitude_sweep": ["--set", "output.plots=[verdicts, agb_error_vs_sweep, faraday_distributions]"],
    "biomass_multichannel": ["--set", "output.plots=[estimator_comparison]", "--set", "requirements.0.curve_points=9"],
}


@pytest.mark.parametrize("path", SCENARIOS, ids=lambda p: p.stem)
def test_scenario_runs_and_writes_plots(path, tmp_path):
    out = tmp_path / path.stem
    assert main(["run", str(path), "-o", str(out), "--no-progress", *QUICK, *EXTRA.get(path.stem, [])]) == 0
    assert (out / "summary.json").is_file() and (out / "results.h5").is_file()
    assert list(out.glob("*.png")), "no plot written"


def test_tradeoff_scenario_reports_axis_crossings(tmp_path):
    import json

    out = tmp_path / "t"
    assert main(["run", str(ROOT / "scenarios" / "men2021_tradeoff_over.yaml"), "-o", str(out),
                 "--no-progress"]) == 0
    s = json.loads((out / "summary.json").read_text())
    fig6 = s["cases"][2]  # boreal 350 t/ha
    assert fig6["inputs"]["scene.forest"] == "boreal_350"
    details = fig6["requirements"][2]["details"]  # 20 % at 99.865 %
    assert details["over.crosstalk_axis_db"] == pytest.approx(-20.166, abs=0.005)  # Fig. 6: -20.16 dB
