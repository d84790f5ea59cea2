"""The plots of a run drawn by this process and a forked helper (e2esim.report.plot_processes): the same outcomes
in the same order as drawn one after another, and whatever goes wrong in the helper ends here as it would
without it."""

from __future__ import annotations

import os

import pytest

from e2esim.report.plot_processes import can_fork, draw_all

pytestmark = pytest.mark.skipif(not can_fork(), reason="no fork or a single core: the plots are drawn here only")

NAMES = [f"plot{i}" for i in range(7)]


def outcome(name: str) -> tuple:
    return [(f"{name}.png", f"caption of {name}")], ""


def test_helper_gives_the_serial_outcomes_in_order():
    parent, drawn_by, done = os.getpid(), [], []

    def draw(name):
        drawn_by.append(os.getpid())  # only this process's draws are seen here
        return outcome(name) + (os.getpid() == parent,)

    results = draw_all(NAMES, draw, done.append, helper=True)
    assert [r[:2] for r in results] == [outcome(n) for n in NAMES]
    assert sorted(done) == sorted(NAMES)  # each plot counted once, whoever drew it
    by_helper = [n for n, r in zip(NAMES, results) if not r[2]]
    assert len(drawn_by) + len(by_helper) == len(NAMES)  # no plot drawn twice
    assert draw_all(NAMES, lambda n: outcome(n), helper=False) == [outcome(n) for n in NAMES]


def test_a_plot_that_fails_in_the_helper_is_drawn_again_here():
    parent = os.getpid()

    def draw(name):
        if os.getpid() != parent:
            raise RuntimeError("only in the helper")
        return outcome(name)

    assert draw_all(NAMES, draw, helper=True) == [outcome(n) for n in NAMES]


def test_an_error_of_a_plot_is_raised_here():
    def draw(name):
        if name == "plot3":
            raise ValueError("plot3 cannot be drawn")
        return outcome(name)

    with pytest.raises(ValueError, match="plot3 cannot be drawn"):
        draw_all(NAMES, draw, helper=True)


def test_the_plots_of_a_helper_that_dies_are_drawn_here():
    parent = os.getpid()

    def draw(name):
        if os.getpid() != parent:
            os._exit(3)  # killed in the middle of a plot
        return outcome(name)

    assert draw_all(NAMES, draw, helper=True) == [outcome(n) for n in NAMES]


def test_without_a_helper_to_be_had_the_plots_are_drawn_here(monkeypatch):
    import multiprocessing.context

    def no_semaphores(self, *args, **kwargs):
        raise OSError(38, "Function not implemented")

    monkeypatch.setattr(multiprocessing.context.BaseContext, "Value", no_semaphores)
    assert draw_all(NAMES, outcome, helper=True) == [outcome(n) for n in NAMES]


@pytest.mark.parametrize("helper", [True, False])
def test_meanwhile_runs_once_here_before_this_process_draws(helper):
    parent, events = os.getpid(), []

    def draw(name):
        if os.getpid() == parent:
            events.append(name)
        return outcome(name)

    def meanwhile():
        assert os.getpid() == parent
        events.append("files")

    assert draw_all(NAMES, draw, helper=helper, meanwhile=meanwhile) == [outcome(n) for n in NAMES]
    assert events[0] == "files" and events.count("files") == 1
    if not helper:
        assert events == ["files", *NAMES]
