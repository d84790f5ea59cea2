"""The array cache is handed to the stages through their services by whoever runs the scenario (issue 27, Build 7):
the runner imports no I/O module for it, and the front doors hand it in."""

from __future__ import annotations

from pathlib import Path

SCENARIO = Path(__file__).resolve().parents[1] / "scenarios" / "men2021_fig1.yaml"


def _services_asked(monkeypatch) -> list:
    from e2esim.runner import executors

    asked = []
    original = executors.default_services
    monkeypatch.setattr(executors, "default_services",
                        lambda progress=False, cache=None, memo=None: asked.append(cache) or original(progress, cache,
                                                                                                     memo))
    return asked


def test_the_front_door_hands_the_array_cache_to_the_stages(monkeypatch):
    import e2esim
    from e2esim.io.array_cache import open_cache

    asked = _services_asked(monkeypatch)
    e2esim.run(SCENARIO, set={"simulation.mode": "analytic"})
    assert asked == [open_cache]


def test_a_run_handed_no_cache_gives_its_stages_none(monkeypatch):
    from e2esim.case import Services
    from e2esim.runner.run import default_services, run_scenario
    from e2esim.runner.scenario import Scenario

    asked = _services_asked(monkeypatch)
    run_scenario(Scenario.load(SCENARIO, ["simulation.mode=analytic"]).resolve(), progress=False)
    assert asked == [None]
    assert default_services().cache_for(None) is None and Services(cache=lambda s: s).cache_for("x") == "x"
