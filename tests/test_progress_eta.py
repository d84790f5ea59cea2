"""The time left on the progress bar is honest from its first update (issue 21, item 11): the first ETA of the
latitude sweep (--workers 2) said 9 minutes for a 69-second run, because tqdm's rate since the start counts the
one-time work of the first blocks (the climatology). No timing is measured here: the estimate is a function of
the (time, cases finished) of the blocks, replayed from a recorded run and from a model of one."""

from pathlib import Path

import pytest
from tqdm import tqdm

from e2esim.runner.progress import BAR_FORMAT, CaseProgress, RemainingTime

LATITUDE_SWEEP = [(28.94, 8), (30.42, 16), (30.65, 24), (32.60, 32), (33.74, 40), (34.28, 48), (36.05, 56),
                  (37.33, 64), (37.46, 72), (40.16, 80), (41.70, 88), (41.82, 96), (44.10, 104), (45.44, 112),
                  (45.48, 120)]
"""(seconds since the start, cases finished) at each block's end: biomass_latitude_sweep.yaml, --workers 2, an empty
climatology cache (120 cases in blocks of 8; the first block ends after the climatology is built)."""


def _replay(timeline, total, workers, done=0):
    remaining = RemainingTime(total, done, workers=workers)
    out, previous = [], done
    for now, finished in timeline:
        remaining.record(now, finished - previous)
        previous = finished
        out.append(remaining.seconds())
    return out


def test_no_estimate_from_the_first_block_where_tqdm_said_minutes():
    total, (now, finished) = 120, LATITUDE_SWEEP[0]
    end = LATITUDE_SWEEP[-1][0]
    naive = now / finished * (total - finished)  # tqdm's rate since the start
    assert naive > 20 * (end - now)  # 405 s announced, 16.5 s left: the defect
    estimates = _replay(LATITUDE_SWEEP, total, workers=2)
    assert estimates[:3] == [None] * 3  # the first round (one block per worker, with its one-time work) and the next
    assert estimates[-1] == 0.0


def test_the_estimate_follows_the_recorded_latitude_sweep():
    end = LATITUDE_SWEEP[-1][0]
    estimates = _replay(LATITUDE_SWEEP, 120, workers=2)
    for (now, _), estimate in zip(LATITUDE_SWEEP[3:-1], estimates[3:-1]):
        left = end - now
        # within a quarter, or one block's time (8 cases at about 3.5 cases/s per worker: 2.3 s)
        assert estimate == pytest.approx(left, rel=0.25, abs=2.3), (now, estimate, left)


@pytest.mark.parametrize("workers", [1, 2, 4])
def test_steady_blocks_after_a_setup_give_the_exact_time_left(workers):
    """Each worker spends `setup` seconds on one-time work, then `per_block` seconds per block of 8 cases, taking
    the next block as soon as it is free: once every worker is past its first block the estimate is exact."""
    setup, per_block, blocks, size = 30.0, 1.5, 24, 8
    free = [0.0] * workers
    timeline = []
    for _ in range(blocks):
        w = min(range(workers), key=free.__getitem__)
        free[w] += per_block + (setup if free[w] == 0.0 else 0.0)
        timeline.append(free[w])
    timeline = [(t, size * (i + 1)) for i, t in enumerate(sorted(timeline))]
    end = timeline[-1][0]
    estimates = _replay(timeline, blocks * size, workers)
    assert estimates[:2 * workers - 1] == [None] * (2 * workers - 1)
    shown = [(i, now, e) for i, ((now, _), e) in enumerate(zip(timeline, estimates)) if e is not None]
    assert len(shown) == blocks - 2 * workers + 1
    for i, now, estimate in shown:  # exact where a round ends, within one block's time between
        if (i + 1) % workers == 0:
            assert estimate == pytest.approx(end - now, rel=1e-12, abs=1e-12), (now, estimate)
        assert abs(estimate - (end - now)) < per_block, (now, estimate, end - now)


def test_a_resumed_run_counts_only_the_cases_it_runs():
    remaining = RemainingTime(total=100, done=60, workers=1)
    remaining.record(50.0, 10)  # 70 done: the first block of this run (its setup included)
    assert remaining.seconds() is None and remaining.text() == "time left: after the first blocks"
    remaining.record(52.0, 10)  # 10 cases in 2 s
    assert remaining.rate() == pytest.approx(5.0) and remaining.seconds() == pytest.approx(4.0)
    assert remaining.text() == "~00:04 left"


def test_the_bar_shows_the_estimate_in_place_of_tqdms():
    times = iter([10.0, 11.0])
    bar = CaseProgress(40, 0, "sweep", enabled=False, workers=1, clock=lambda: next(times))
    bar.update(10)
    assert bar.remaining.seconds() is None
    bar.update(10)
    assert bar.remaining.seconds() == pytest.approx(2.0) and bar.bar.postfix == "~00:02 left"
    bar.close()
    line = tqdm.format_meter(20, 40, 11.0, bar_format=BAR_FORMAT, postfix="~00:02 left", prefix="sweep")
    assert line.startswith("sweep:  50%|") and line.endswith("20/40 [00:11, ~00:02 left]")


def test_when_auto_hands_the_rest_to_a_pool_the_time_left_is_the_pools():
    """--workers auto: 2 serial blocks of 4 cases a second, then 2 workers with blocks of 2 cases every 0.5 s
    (8 cases a second). After the pool's second round the serial rate would say 8 s for the 32 cases left; the
    pool's own rate says 4 s, and nothing is said before its second round (its first is each worker's start)."""
    times = iter([1.0, 2.0, 2.6, 2.6, 3.1, 3.1])
    bar = CaseProgress(48, 0, "sweep", enabled=False, workers=1, clock=lambda: next(times))
    bar.update(4)
    bar.update(4)
    assert bar.remaining.seconds() == pytest.approx(10.0)  # 40 cases at the serial 4 a second
    bar.pool_started(2)
    assert bar.remaining.seconds() is None and bar.bar.postfix == "time left: after the first blocks"
    bar.update(2)
    bar.update(2)  # the pool's first round
    assert bar.remaining.seconds() is None
    bar.update(2)
    bar.update(2)
    assert bar.remaining.seconds() == pytest.approx(4.0) and bar.bar.postfix == "~00:04 left"
    bar.close()


def test_the_outputs_bar_names_each_step_and_leaves_the_first_out_of_its_rate():
    """Issue 28, Build 4: the plots and files of a run's outputs get a bar; its time left comes from the steps done
    after the first (matplotlib's one-time set-up comes with the first plot), on a fake clock."""
    from e2esim.runner.progress import StepProgress

    times = iter([12.0, 14.0, 15.0])  # the first step (set-up) 12 s, then 2 s and 1 s
    steps = StepProgress(5, "outputs", enabled=False, clock=lambda: next(times))
    with steps.step("verdicts"):
        assert steps.bar.desc == "outputs (verdicts)"
    assert steps.remaining.seconds() is None and steps.remaining.text() == "time left: after the first steps"
    with steps.step("tradeoff"):
        pass
    assert steps.remaining.seconds() == pytest.approx(3 * 2.0)  # 1 step in 2 s after the first: 3 left
    with steps.step("results.h5"):
        pass
    assert steps.remaining.seconds() == pytest.approx(2 * 1.5) and steps.bar.postfix == "~00:03 left"
    assert steps.remaining.done == 3
    steps.close()


def test_write_outputs_counts_every_plot_and_file(tmp_path, monkeypatch):
    """Every output step passes through the bar: the plots, results.h5, summary.json and the report."""
    import e2esim
    from e2esim.report.plots import requested_plots
    from e2esim.runner import outputs, progress

    counted = []

    class Counting(progress.StepProgress):
        def close(self):
            counted.append((self.remaining.done, self.remaining.total))
            super().close()

    monkeypatch.setattr(outputs, "StepProgress", Counting)
    scenario = Path(__file__).resolve().parents[1] / "scenarios" / "men2021_fig1.yaml"
    results = e2esim.run(scenario, set={"simulation.mode": "analytic"}, output=tmp_path / "r")
    steps = len(requested_plots(results.run)) + 3
    assert steps >= 5 and counted == [(steps, steps)]


@pytest.mark.parametrize("shown", [True, False])
def test_a_serial_run_with_a_bar_hands_its_stages_one(monkeypatch, shown):
    """Blocks run in this process get the progress bar for long kernels (the global climatology's months) when
    the run shows a bar: they used to get none, so the climatology build drew nothing."""
    import e2esim
    from e2esim.runner import executors

    asked = []
    original = executors.default_services

    def services(progress=False, cache=None, memo=None):
        asked.append(progress)
        return original(progress, cache, memo)
    monkeypatch.setattr(executors, "default_services", services)
    scenario = Path(__file__).resolve().parents[1] / "scenarios" / "men2021_fig1.yaml"
    e2esim.run(scenario, set={"simulation.mode": "analytic"}, progress=shown)
    assert asked == [shown]
