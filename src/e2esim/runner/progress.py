"""The progress bar of a run, with a time left that is honest from its first update.

tqdm estimates the time left from the rate since the start. A run's first blocks carry one-time work (a
climatology built and cached, imports, the caches of each worker process): in the latitude sweep
(``--workers 2``) the first block ended after 29 s of a 46 s run, and the estimate then was 405 s. Here the
first round of blocks (one per worker, each with its worker's one-time work) is left out: the rate is measured
from the end of that round to the end of the latest whole round (``RemainingTime``), and no estimate is shown
until a second round has ended, so that the rate spans whole blocks of every worker.
"""

from __future__ import annotations

import threading
import time
import warnings
from contextlib import contextmanager
from dataclasses import dataclass

from tqdm import TqdmExperimentalWarning

with warnings.catch_warnings():  # what tqdm.auto does, without its asyncio mixin (asyncio costs every process 20 ms)
    warnings.simplefilter("ignore", category=TqdmExperimentalWarning)
    from tqdm.autonotebook import tqdm  # a notebook's widget bar in Jupyter, else the console bar

BAR_FORMAT = "{desc}: {percentage:3.0f}%|{bar}| {n_fmt}/{total_fmt} [{elapsed}{postfix}]"
"""tqdm's bar with the time left of ``RemainingTime`` (its postfix) in place of tqdm's own estimate."""


@dataclass
class RemainingTime:
    """Time left of a run of ``total`` cases, ``done`` of them finished before it started (a resumed run), on
    ``workers`` workers.

    ``record(now, cases)`` after each block. Blocks end in rounds of ``workers``; the first round (each worker's
    one-time work) is left out: the rate is the cases finished from the end of the first round to the end of the
    latest whole round, over the time between (None until a second round has ended). Whole rounds make it exact
    for workers in step; between two round ends it lags by less than one block's time.
    """

    total: int
    done: int = 0
    workers: int = 1
    blocks: int = 0
    origin: tuple | None = None  # (time, cases done) at the end of the first round
    round_end: tuple | None = None  # (time, cases done) at the end of the latest whole round
    what: str = "blocks"  # what is counted, in the text shown before the rate is measured

    def record(self, now: float, cases: int) -> None:
        self.done += int(cases)
        self.blocks += 1
        if self.blocks % self.workers == 0:
            self.round_end = (now, self.done)
            if self.origin is None:
                self.origin = self.round_end

    def rate(self) -> float | None:
        """Cases per second after the first round of blocks, or None while that is not measured."""
        if self.blocks < 2 * self.workers:
            return None
        (t0, d0), (t1, d1) = self.origin, self.round_end
        return (d1 - d0) / (t1 - t0) if t1 > t0 and d1 > d0 else None

    def seconds(self) -> float | None:
        """Seconds left as of the latest block: 0 when every case is done, None while the rate is not known."""
        if self.done >= self.total:
            return 0.0
        rate = self.rate()
        return None if rate is None else (self.total - self.done) / rate

    def text(self) -> str:
        seconds = self.seconds()
        if seconds is None:
            return f"time left: after the first {self.what}"
        return f"~{tqdm.format_interval(seconds)} left"


class CaseProgress:
    """A tqdm bar of finished cases whose time left is ``RemainingTime``'s. ``update(cases)`` after each block.
    A shown bar is redrawn every ``TICK_S`` between blocks, so that its elapsed time moves through a long first
    block (a climatology built in a worker process, which cannot draw a bar of its own)."""

    TICK_S = 1.0

    def __init__(self, total: int, initial: int, description: str, enabled: bool, workers: int = 1,
                 clock=time.monotonic):
        self.clock = clock
        self.remaining = RemainingTime(total, initial, workers=max(1, workers))
        self.bar = tqdm(total=total, initial=initial, desc=description, unit="case", disable=not enabled,
                        leave=False, bar_format=BAR_FORMAT, postfix=self.remaining.text())
        self.stop = threading.Event()
        self.ticker = threading.Thread(target=self._tick, daemon=True, name="e2esim-progress") if enabled else None
        if self.ticker is not None:
            self.ticker.start()

    def _tick(self) -> None:
        while not self.stop.wait(self.TICK_S):
            self.bar.refresh()

    def update(self, cases: int) -> None:
        self.remaining.record(self.clock(), cases)
        self.bar.set_postfix_str(self.remaining.text(), refresh=False)
        self.bar.update(cases)

    def pool_started(self, workers: int) -> None:
        """The rest of the run goes to ``workers`` worker processes (``--workers auto``): the time left is measured
        afresh, from their rounds of blocks (the first left out: each worker's start), not at this process's rate."""
        self.remaining = RemainingTime(self.remaining.total, self.remaining.done, workers=max(1, workers))
        self.bar.set_postfix_str(self.remaining.text(), refresh=False)

    def close(self) -> None:
        self.stop.set()
        if self.ticker is not None:
            self.ticker.join()  # not drawing while the bar is cleared
        self.bar.close()


class StepProgress:
    """A bar of named steps (the plots and files of a run's outputs): ``with bar.step(name): ...`` around each. The
    step in progress is named on the bar; the time left is ``RemainingTime``'s, the first step (matplotlib's one-time
    set-up comes with the first plot) left out of the rate."""

    def __init__(self, total: int, description: str, enabled: bool, clock=time.monotonic):
        self.clock, self.description = clock, description
        self.remaining = RemainingTime(total, what="steps")
        self.bar = tqdm(total=total, desc=description, unit="step", disable=not enabled, leave=False,
                        bar_format=BAR_FORMAT, postfix=self.remaining.text())

    @contextmanager
    def step(self, name: str):
        self.bar.set_description_str(f"{self.description} ({name})", refresh=False)
        self.bar.refresh()
        yield
        self.remaining.record(self.clock(), 1)
        self.bar.set_postfix_str(self.remaining.text(), refresh=False)
        self.bar.update(1)

    def close(self) -> None:
        self.bar.close()


__all__ = ["BAR_FORMAT", "CaseProgress", "RemainingTime", "StepProgress"]
