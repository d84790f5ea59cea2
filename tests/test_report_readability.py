"""An outlier never hides the other cases, labels are shown whole, and a huge relative error is read as what it
is (issue 21, item 11). biomass_multichannel's VV estimate without Faraday correction (boreal 200 t/ha) has an
AGB error of 1.8e7 % (its power law's exponent is 0.0612: the AGB estimate is sigma_vv to the power 16.3), and
the linear margin and budget axes that reached it drew the other 15 cases as zero; the case labels were cut
("estimator=..."), hiding the key that tells the cases apart."""

import numpy as np
import pytest

from e2esim.report import budget_plots, sweep_plots
from e2esim.report.document import verdict_lines
from e2esim.report.labels import wrapped
from e2esim.report.outliers import OUTLIER_FACTOR, axis_cut, error_meaning
from e2esim.report.plot_base import figure_settings


def test_an_outlier_is_cut_and_the_axis_spans_the_others():
    margins = np.array([7.2, -48.7, -59.0, -1.79e7, 7.2, 10.6, 11.9, -56.7, 7.6, 11.3, 11.1, -366.0, 7.6, 14.1, 16.4])
    cut = axis_cut(margins)
    assert cut is not None and cut.edge == pytest.approx(1.15 * 366.0)
    assert cut.cut(margins).tolist() == [v == -1.79e7 for v in margins]
    low, high = cut.limits(margins)
    assert -1.1 * cut.edge < low < -366.0 and 16.4 < high < 100.0
    assert axis_cut(margins[margins > -1e6]) is None  # 366 against 59: a wide spread, but no outlier
    assert axis_cut([1.0, 2.0, 3.0]) is None and axis_cut([]) is None and axis_cut([np.nan, 1.0]) is None
    # the reference (a limit drawn with the values) is kept on the axis: 50 is not 10 times a limit of 20
    assert axis_cut([0.1, 0.2, 50.0], reference=[20.0]) is None
    assert axis_cut([0.1, 0.2, 50.0]) is not None
    # outliers are fewer than half of the values: two equal groups far apart are both kept
    assert axis_cut([1.0, 1.0, 1e6, 1e6]) is None
    assert axis_cut([1.0, 1.0, 1.0, 1e6, 1e6]).edge == pytest.approx(1.15) and OUTLIER_FACTOR == 10


def test_a_label_is_wrapped_at_its_keys_and_never_cut():
    label = "15: forest=tropical_338, calibration.0.type=faraday_correction, estimator=vv"
    text = wrapped(label, 40)
    assert text == "15: forest=tropical_338,\ncalibration.0.type=faraday_correction,\nestimator=vv"
    assert text.replace(",\n", ", ") == label
    assert wrapped("a=1, b=2", 40) == "a=1, b=2" and wrapped("x=" + "y" * 50, 10) == "x=" + "y" * 50


def test_a_huge_relative_error_is_read_as_a_factor():
    assert error_meaning(1.79e7, "%") == "an error of 1.79e+07 %, about 1.8e+05 times the true value"
    assert error_meaning(386.0, "%") == "" and error_meaning(5e4, "t/ha") == "" and error_meaning(np.nan, "%") == ""


def _drawn(monkeypatch, module, plot, result, tmp_path):
    figures = []

    def keep(fig, folder, name, tight=None):
        figures.append(fig)
        return f"{name}.png"

    monkeypatch.setattr(module, "save", keep)
    with figure_settings():
        out = plot(result, tmp_path, result.scenario.output)
    return figures[0], out[0][1]


def _tick_texts(ax) -> list:
    return [t.get_text().replace(",\n", ", ") for t in ax.get_yticklabels()]


@pytest.mark.parametrize("module, plot", [(sweep_plots, sweep_plots.plot_verdicts),
                                          (budget_plots, budget_plots.plot_error_budget)])
def test_the_multichannel_plots_show_every_case(monkeypatch, tmp_path, quick_run, module, plot):
    result, _ = quick_run("biomass_multichannel")
    values = np.array([c.verdicts[0].value for c in result.cases])
    worst = int(np.argmax(values))
    assert values[worst] > 1e6 and np.sort(values)[-2] < 1e3  # the shipped outlier (VV, uncalibrated, boreal 200)
    fig, caption = _drawn(monkeypatch, module, plot, result, tmp_path)
    ax = fig.axes[0]
    low, high = ax.get_xlim()
    assert max(abs(low), abs(high)) < 1e3  # the axis spans the other cases: the largest of them is a few hundred %
    texts = [t.get_text() for t in ax.texts]
    assert any(f"{values[worst] if module is budget_plots else 20.0 - values[worst]:.3g} %" in t for t in texts), texts
    assert "far beyond the others" in caption
    # every case label whole (wrapped lines joined back), the estimator that tells the cases apart included
    assert _tick_texts(ax) == [f"{c.index}: {c.label}" for c in result.cases]
    assert not any("…" in t for t in _tick_texts(ax))


def test_the_command_line_reads_the_outlier_as_a_factor(quick_run):
    result, _ = quick_run("biomass_multichannel")
    line = verdict_lines(result)[0]
    assert "; an error of 1.79e+07 %, about 1.8e+05 times the true value)" in line, line


def test_the_tradeoff_panels_share_one_legend_and_their_axis_labels(monkeypatch, tmp_path, quick_run):
    # twelve copies of one legend and of two axis labels said nothing more and were a third of the figure's text
    from e2esim.report import plots

    result, _ = quick_run("biomass_multichannel")
    fig, _ = _drawn(monkeypatch, plots, plots.plot_tradeoff, result, tmp_path)
    axes = [ax for ax in fig.axes if ax.axison]
    assert len(axes) == 12 and len(fig.legends) == 1 and not any(ax.get_legend() for ax in axes)
    entries = [t.get_text() for t in fig.legends[0].get_texts()]
    assert entries == [ln.get_label() for ln in axes[0].get_lines()]  # every curve, the star and the residual
    assert any("specification (stated)" in e for e in entries) and "residual after calibration" in entries
    conv = result.cases[0].get("instrument").level_convention
    assert [ax.get_xlabel() for ax in axes] == [""] * 10 + [f"crosstalk (dB, {conv})"] * 2  # the bottom row
    assert [ax.get_ylabel() for ax in axes] == [f"channel imbalance (dB, {conv})", ""] * 6  # the first column
    assert [ax.get_title() for ax in axes] == [wrapped(c.label, 70) for c in result.cases[:12]]


def test_panels_with_different_legends_keep_their_own():
    import matplotlib.pyplot as plt

    from e2esim.report.plots import _label_panels

    fig, axes = plt.subplots(1, 2)
    axes[0].plot([0, 1], [0, 1], label="a")
    axes[1].plot([0, 1], [0, 1], label="b")
    labels = [("x", "y", ((ln.get_label(),) for ln in ax.get_lines())) for ax in axes]
    labels = [(x, y, tuple(e)) for x, y, e in labels]
    _label_panels(fig, axes, labels, columns=2)
    assert not fig.legends and [ax.get_legend().get_texts()[0].get_text() for ax in axes] == ["a", "b"]
    assert [(ax.get_xlabel(), ax.get_ylabel()) for ax in axes] == [("x", "y"), ("x", "y")]
    plt.close(fig)


def test_the_margins_per_case_share_their_case_labels(monkeypatch, tmp_path, quick_run):
    result, _ = quick_run("biomass_default")
    assert len(result.requirement_names) == 2
    fig, _ = _drawn(monkeypatch, sweep_plots, sweep_plots.plot_verdicts, result, tmp_path)
    first, second = fig.axes
    assert _tick_texts(first) == [f"{c.index}: {c.label}" for c in result.cases]  # whole, once
    assert not any(t.get_visible() and t.get_text() for t in second.get_yticklabels())
    assert first.get_ylim() == second.get_ylim() and first.yaxis_inverted()  # case 0 at the top of both
    for ax, j in ((first, 0), (second, 1)):  # each panel its requirement's margins, case by case
        widths = [p.get_width() for p in ax.patches]
        assert widths == pytest.approx([c.verdicts[j].margin for c in result.cases], nan_ok=True)
