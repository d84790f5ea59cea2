"""`e2esim run` answers a scenario's own question (its solve or allocate section) and shows it first: report,
printed lines, summary.json and results.h5 (issue 23, item 7; e2esim.flowdown.answer)."""

from __future__ import annotations

import json

import h5py
import yaml

from e2esim.cli import main
from e2esim.flowdown.inverse import solve
from e2esim.flowdown.report import solve_lines


def _scenario(tmp_path, **sections):
    raw = {
        "name": "asks",
        "scene": {"type": "table1_forest", "forest": "boreal_200"},
        "instrument": {"type": "biomass"},
        "ionosphere": {"type": "gaussian_faraday", "mean_deg": 20.0, "sd_deg": 5.0},
        "propagation": {"type": "hv_backscatter_error"},
        "retrieval": {"type": "power_law"},
        "requirements": [{"type": "agb_error_bound", "sources": "systematic", "bound_percent": 20}],
        "simulation": {"mode": "analytic", "seed": 7},
        "output": {"plots": ["verdicts"]},
        **sections,
    }
    path = tmp_path / "asks.yaml"
    path.write_text(yaml.safe_dump(raw))
    return path, raw


SOLVE = {"solve": {"for": ["instrument.crosstalk.level_db"], "bounds": [[-60, -5]], "worst_case": True}}


def test_run_answers_the_solve_section_first(tmp_path, capsys):
    path, raw = _scenario(tmp_path, **SOLVE)
    assert main(["run", str(path), "-o", str(tmp_path / "out"), "--no-progress"]) == 0
    expected = solve_lines("asks", solve(raw, ["instrument.crosstalk.level_db"], (-60, -5), worst_case=True))
    printed = capsys.readouterr().out.splitlines()
    assert [line.removeprefix("  answer: ") for line in printed[1:1 + len(expected)]] == [e.strip() for e in expected]
    report = (tmp_path / "out" / "report.md").read_text().splitlines()
    assert report[2] == "## Answer" and report[4] == expected[0].strip()
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert list(summary)[:2] == ["scenario", "answer"] and summary["answer"]["lines"] == expected
    limit = summary["answer"]["result"]["requirements"][0]["limit"]
    assert -40 < limit < -10  # the crosstalk at which the boreal 200 t/ha case meets +-20 % (test_solve.py)
    with h5py.File(tmp_path / "out" / "results.h5") as f:
        assert f["answer"].attrs["question"] == "solve"
        assert json.loads(f["answer/result"][()])["requirements"][0]["limit"] == limit


def test_answer_off_and_two_questions(tmp_path, capsys):
    path, _ = _scenario(tmp_path, **SOLVE, output={"answer": False})
    assert main(["run", str(path), "-o", str(tmp_path / "off"), "--no-progress"]) == 0
    assert "answer" not in json.loads((tmp_path / "off" / "summary.json").read_text())
    path, _ = _scenario(tmp_path, **SOLVE, allocate={"sources": {"crosstalk": "instrument.crosstalk.level_db"}})
    assert main(["run", str(path), "-o", str(tmp_path / "both"), "--no-progress"]) == 2
    assert "a scenario asks one question" in capsys.readouterr().err
