"""The plots of a run drawn by this process and a forked helper (e2esim.report.plot_processes): the same outcomes
in the same order as drawn one after another, and whatever goes wrong in the helper ends here as it would
without it."""

from __future__ import annotations

import os
import time

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


def test_this_process_does_its_own_work_first_while_the_helper_draws(tmp_path):
    """The run's data files (``first``) are written here while the helper draws: a map's figures are one plot, as
    long as the files, and the two overlap instead of following one another."""
    parent, events = os.getpid(), []
    marker = tmp_path / "the helper drew"

    def draw(name):
        if os.getpid() != parent:
            marker.touch()
        else:
            events.append(name)
        return outcome(name)

    def first():
        deadline = time.monotonic() + 60
        while not marker.exists() and time.monotonic() < deadline:
            time.sleep(0.01)
        events.append(("first", marker.exists()))

    assert draw_all(NAMES, draw, helper=True, first=first) == [outcome(n) for n in NAMES]
    assert events[0] == ("first", True)  # before any plot of this process's, while the helper drew
    events.clear()
    assert draw_all(NAMES, draw, helper=False, first=lambda: events.append("first")) == [outcome(n) for n in NAMES]
    assert events == ["first", *NAMES]


def test_an_error_of_this_process_own_work_is_raised():
    def first():
        raise OSError(28, "No space left on device")

    with pytest.raises(OSError, match="No space left"):
        draw_all(NAMES, outcome, helper=True, first=first)
