"""The inverse solve (issue 23, item 4): ``e2esim solve`` / ``e2esim.solve`` find where each requirement is exactly
met through the engine's forward model. It reproduces the level margins (crosstalk, channel imbalance, NESZ) and the
trade-off curves' axis crossings and points of e2esim.requirements (root finding on the error model's levels) to
0.01 dB, reports "every value meets it" / "no value meets it" as states, and refuses bad input with exit status 2."""

import json

import numpy as np
import pytest

import e2esim
from e2esim.cli import main
from e2esim.errors import UserError
from e2esim.runner.run import run_scenario
from e2esim.runner.scenario import Scenario

CROSSTALK, IMBALANCE, NESZ = "instrument.crosstalk.level_db", "instrument.channel_imbalance.level_db", \
    "instrument.nesz_db"


def small(forests=("boreal_50", "boreal_200", "tropical_338"), rmse=True, **instrument):
    raw = {
        "name": "small",
        "scene": {"type": "table1_forest", "forest": "boreal_200"},
        "instrument": {"type": "biomass", **instrument},
        "ionosphere": {"type": "gaussian_faraday", "mean_deg": 20.0, "sd_deg": 5.0},
        "propagation": {"type": "hv_backscatter_error"},
        "retrieval": {"type": "power_law"},
        "requirements": [{"type": "agb_error_bound", "sources": "systematic", "bound_percent": 20,
                          "level_margins": True, "tradeoff_curve": True, "curve_points": 15}],
        "simulation": {"mode": "analytic", "seed": 7},
    }
    if rmse:
        raw["requirements"].append({"type": "agb_rmse", "max_percent": 20})
    if forests:
        raw["sweep"] = {"parameters": {"scene.forest": list(forests)}}
    return raw


def details(raw):
    result = run_scenario(Scenario(raw, "small.yaml").resolve(), progress=False)
    return lambda key: result.table.detail(0, key), result


@pytest.mark.parametrize("key, level", [(CROSSTALK, "crosstalk"), (IMBALANCE, "channel_imbalance"),
                                        (NESZ, "nesz")])
def test_solve_reproduces_the_level_margins(key, level):
    """Without calibration the instrument's level is the error model's: the value of the key where the bound is
    exactly met is the level margin's limit (requirements/margins.py), case by case, to 0.01 dB."""
    detail, _ = details(small())
    result = e2esim.solve(small(), key, bounds=(-60, -5))
    answer = result.answers[0]
    assert answer.state == ["met at"] * 3
    np.testing.assert_allclose(answer.value, detail(f"{level}.limit_db"), atol=0.01)
    assert answer.side == ["at most"] * 3
    assert answer.binding == int(np.argmin(detail(f"{level}.limit_db")))
    assert abs(answer.margins[answer.binding]) < 1e-3 and np.all(answer.margins > -1e-3)


@pytest.mark.parametrize("key, off, axis", [(CROSSTALK, "channel_imbalance", "crosstalk_axis_db"),
                                            (IMBALANCE, "crosstalk", "imbalance_axis_db")])
def test_solve_reproduces_the_tradeoff_curves_axis_crossings(key, off, axis):
    """With the other level off, the value where the bound (both sides) is met is where the trade-off curve meets
    the axis (Men et al. 2021, Section V-B points 3 and 6): the smaller of the two sides' crossings, to 0.01 dB."""
    detail, _ = details(small())
    crossing = np.minimum(detail(f"over.{axis}"), detail(f"under.{axis}"))
    result = e2esim.solve(small(**{off: {"level_db": None}}), key, bounds=(-60, -5))
    np.testing.assert_allclose(result.answers[0].value, crossing, atol=0.01)


def test_two_keys_give_the_tradeoff_curve():
    """The boundary of crosstalk and channel imbalance for one case and one requirement is its trade-off curve (the
    lower of the two sides), point for point, to 0.01 dB."""
    raw = small(forests=(), rmse=False)
    _, result = details(raw)
    curve = result.table.requirements[0].curves[0]
    x = curve["crosstalk_db"]
    inside = (x >= -40) & (x <= -24)
    raw["requirements"][0]["curve_crosstalk_db"] = [-40, -24]
    raw["requirements"][0]["curve_points"] = int(inside.sum())
    _, result = details(raw)
    curve = result.table.requirements[0].curves[0]
    found = e2esim.solve(raw, [CROSSTALK, IMBALANCE], bounds=[(-40, -24), (-60, -5)], points=int(inside.sum()))
    np.testing.assert_allclose(found.x, curve["crosstalk_db"], atol=1e-12)
    np.testing.assert_allclose(found.y, np.minimum(curve["over.imbalance_db"], curve["under.imbalance_db"]),
                               atol=0.01)
    assert set(found.state) == {"met at"} and set(found.side) == {"at most"}


def test_the_worst_case_is_the_strictest_case():
    detail, _ = details(small())
    result = e2esim.solve(small(), CROSSTALK, bounds=(-60, -5), worst_case=True)
    limits = detail("crosstalk.limit_db")
    assert result.answers[0].limit == pytest.approx(limits.min(), abs=0.01)
    assert result.answers[0].binding == int(np.argmin(limits))


def test_every_value_and_no_value_are_states_not_errors():
    """Between -45 and -18 dB every crosstalk meets the RMSE requirement in every case, and the bound in the
    tropical case; between -20 and -10 dB no crosstalk meets the bound in the boreal cases, while the tropical case
    is met at -16.9 dB."""
    result = e2esim.solve(small(), CROSSTALK, bounds=(-45, -18))
    assert result.answers[1].state == ["every value meets it"] * 3
    assert result.answers[0].state == ["met at", "met at", "every value meets it"]
    result = e2esim.solve(small(), CROSSTALK, bounds=(-20, -10))
    assert result.answers[0].state == ["no value meets it", "no value meets it", "met at"]
    assert result.answers[0].binding == 0


def run_cli(capsys, *argv):
    code = main(list(argv))
    return code, capsys.readouterr()


@pytest.fixture
def scenario_file(tmp_path):
    def write(raw):
        path = tmp_path / "small.yaml"
        path.write_text(json.dumps(raw))
        return str(path)
    return write


@pytest.mark.parametrize("raw, argv, message", [
    (small(), ["--for", "instrument.crosstalk.level_dbb"], "unknown key: it names no parameter"),
    (small(), ["--for", "nosuch.key"], "unknown key"),
    (small(), ["--for", "instrument.crosstalk.convention"], "not a numeric parameter (of type str)"),
    (small(), ["--for", "instrument.crosstalk.term_offsets_db"], "not a numeric parameter (a list)"),
    (small(forests=()) | {"sweep": {"parameters": {"ionosphere.sd_deg": [1.0, 5.0]}}},
     ["--for", "ionosphere.sd_deg"], "the sweep sets this key"),
    (small() | {"calibration": [{"type": "residual_faraday", "sd_deg": 1.0}]}, ["--for", "calibration.0.sd_deg"],
     "no effect on any requirement in any case"),
    (small(), ["--for", CROSSTALK, "--bounds", "-45", "-40"], "no requirement changes sign in any case"),
    (small(), ["--for", CROSSTALK, "--bounds", "-10", "-20"], "expected two finite numbers LO < HI"),
    (small(), ["--for", CROSSTALK, "--bounds", "-300", "-20"], "outside the allowed range"),
    (small(), ["--for", "ionosphere.mean_deg", "--for", "ionosphere.mean_deg"], "two different keys"),
    (small(), [], "give --for KEY"),
    (small() | {"simulation": {"mode": "montecarlo"}}, ["--for", CROSSTALK], "need the analytic model"),
    (small(), ["--for", CROSSTALK, "--workers", "0"], "--workers 0: expected a number of processes >= 1"),
])
def test_bad_solves_exit_2_with_a_message(capsys, scenario_file, raw, argv, message):
    code, out = run_cli(capsys, "solve", scenario_file(raw), *argv)
    assert code == 2 and message in out.err and "Traceback" not in out.err


def test_the_cli_prints_the_answer_first_and_writes_it(capsys, scenario_file, tmp_path):
    code, out = run_cli(capsys, "solve", scenario_file(small()), "--for", NESZ, "--bounds", "-40", "-10",
                        "--worst-case", "-o", str(tmp_path / "out"))
    assert code == 0
    first = out.out.splitlines()
    assert "worst case" in first[0] and "met for instrument.nesz_db <= -24.37" in first[1]
    report = (tmp_path / "out" / "solve.md").read_text().splitlines()
    assert "met for instrument.nesz_db <= -24.37" in "\n".join(report[:8])
    saved = json.loads((tmp_path / "out" / "solve.json").read_text())
    assert saved["requirements"][0]["limit"] == pytest.approx(-24.371, abs=0.01)


def test_a_solve_section_states_the_question(capsys, scenario_file):
    raw = small() | {"solve": {"for": [NESZ], "bounds": [[-40, -10]], "worst_case": True}}
    code, out = run_cli(capsys, "solve", scenario_file(raw))
    assert code == 0 and "instrument.nesz_db <= -24.37" in out.out
    Scenario(raw, "x.yaml").resolve()  # e2esim run accepts the section


def test_a_bad_key_from_python_is_a_user_error():
    with pytest.raises(UserError, match="unknown key"):
        e2esim.solve(small(), "instrument.nope")


def test_the_scan_brackets_a_region_that_passes_only_inside_the_range():
    """Margins that fail at both ends of the range and pass in its middle are "met at" the first crossing from the low
    end (two crossings seen), not "no value meets it"."""
    from e2esim.flowdown.scan import scan_brackets

    xs = np.linspace(0.0, 8.0, 9)
    m = np.array([[-3.0, -2.0, -1.0, 1.0, 2.0, 1.0, -1.0, -2.0, -3.0],
                  xs + 1.0, -xs - 1.0, [2.0] * 9, [np.nan] + [1.0] * 8])
    state, a, b, fa, fb, side_lo, crossings = scan_brackets(xs, m)
    assert list(state) == ["met at", "every value meets it", "no value meets it", "no effect", "not applicable"]
    assert (a[0], b[0], fa[0], fb[0], bool(side_lo[0]), crossings[0]) == (2.0, 3.0, -1.0, 1.0, False, 2)


def test_vectorised_brent_finds_every_root_to_its_tolerance():
    from e2esim.flowdown.brent import brent

    c = np.linspace(0.1, 1.5, 7)

    def g(idx, x):
        return np.tanh(3 * (x - c[idx])) + 0.1 * (x - c[idx]) ** 3
    everything = np.arange(7)
    roots, calls = brent(g, np.full(7, -1.0), np.full(7, 2.0), g(everything, np.full(7, -1.0)),
                         g(everything, np.full(7, 2.0)), 1e-10)
    np.testing.assert_allclose(roots, c, atol=1e-10)
    assert calls < 20
