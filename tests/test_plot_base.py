"""What the report's plots share (e2esim.report.plot_base): a layout with room below the panels measured once gives
matplotlib's own layout, and the objects that exist before drawing are frozen only while the plots are drawn."""

from __future__ import annotations

import gc

import matplotlib.pyplot as plt
import pytest

from e2esim.report.plot_base import figure_settings, older_objects_left_to_rest, panel_grid, tight_layout_in


def _panels():
    with figure_settings():
        fig, axes = panel_grid(5, 2, (3, 2))
    for i, ax in enumerate(axes):
        ax.plot([0, 1e3 * (i + 1)], [0, 1])
        ax.set_title(f"panel {i}")
        ax.set_xlabel("crosstalk (dB)")
    fig.legend(handles=axes[0].get_lines(), labels=["a line"], loc="lower center")
    return fig


def test_tight_layout_in_is_matplotlibs_layout_measured_once():
    rect = (0, 0.12, 1, 1)
    ours, theirs = _panels(), _panels()
    tight_layout_in(ours, rect)
    theirs.tight_layout(rect=rect)
    params = ("left", "right", "bottom", "top", "wspace", "hspace")
    assert [getattr(ours.subplotpars, p) for p in params] == [getattr(theirs.subplotpars, p) for p in params]
    assert [ax.get_position().bounds for ax in ours.axes] == [ax.get_position().bounds for ax in theirs.axes]
    assert all("get_tightbbox" not in vars(ax) for ax in ours.axes)  # the panels measure afresh afterwards
    plt.close(ours)
    plt.close(theirs)


def test_tight_layout_in_measures_each_panel_once(monkeypatch):
    fig = _panels()
    measured = []
    original = type(fig.axes[0]).get_tightbbox

    def counted(ax, *args, **kwargs):
        measured.append(ax)
        return original(ax, *args, **kwargs)

    monkeypatch.setattr(type(fig.axes[0]), "get_tightbbox", counted)
    tight_layout_in(fig, (0, 0.12, 1, 1))
    visible = [ax for ax in fig.axes if ax.get_visible()]
    assert sorted(map(id, measured)) == sorted(map(id, visible))  # matplotlib alone: each twice
    measured.clear()
    fig.tight_layout(rect=(0, 0.12, 1, 1))
    assert len(measured) == 2 * len(visible)
    plt.close(fig)


def test_objects_frozen_only_while_drawing():
    if gc.get_freeze_count():
        pytest.skip("this process has frozen objects already")
    with older_objects_left_to_rest():
        assert gc.get_freeze_count() > 0
    assert gc.get_freeze_count() == 0


def test_a_callers_frozen_objects_stay_frozen():
    mine = [object()]  # a container the collector tracks: frozen, it is in none of the three generations
    gc.freeze()
    try:
        with older_objects_left_to_rest():
            pass
        # (the count is no check: frozen objects that lose their last reference meanwhile leave it)
        assert gc.get_freeze_count() > 0 and not any(o is mine for o in gc.get_objects())
    finally:
        gc.unfreeze()
    assert any(o is mine for o in gc.get_objects())  # what the check above tells apart
