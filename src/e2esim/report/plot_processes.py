"""The plots of a run drawn by two processes at once: this one and one forked helper.

Drawing a figure is matplotlib's Python (text layout above all) and holds one core; the plots of a run do not
depend on one another, so a second process about halves the time of a run's plots.
The helper is forked after the run, so it has the run's results without pickling them; both processes take the
next plot until none is left, the helper from the end of the list and this one from its start (opposite ends: a
list whose costliest plot comes last, as biomass_multichannel's twelve-panel trade-off curves after three
one-panel figures, is not left to one process after the others), and the helper sends back what each of its plots
gave (the file names and captions, or why it drew nothing). This process first writes the output files that need
no plot (``meanwhile``: results.h5 and summary.json) while the helper draws, so it starts on the plots later: the
helper, which starts at once, takes from the end, where a list's costliest plots tend to be (biomass_default:
the error histograms and the Faraday-rotation distributions, then the site map, are about as much drawing as
the files and the plots before them). Every figure is drawn by the same code either way, so
the files are the same; the list comes back in the order of the plots.

Whatever goes wrong in the helper ends in this process as it would without it: a plot whose drawing raised an
error there (or that the helper took and did not report, because it died) is drawn again here, where the error
is raised as usual. Ctrl-C and stop signals end the helper with this process (it is stopped and waited for
before the outputs of the attempt are removed). Without ``fork`` (Windows), with one core, or in a daemonic
process (a worker of a pool, which may not have children), the plots are drawn here one after another.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os

_DONE = None  # what the helper sends when it has taken every plot
_FAILED = "failed"  # the outcome the helper sends for a plot that raised an unexpected error


def usable_cores() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def can_fork() -> bool:
    """Whether a helper process can be forked here (module docstring)."""
    return ("fork" in multiprocessing.get_all_start_methods() and usable_cores() > 1
            and not multiprocessing.current_process().daemon)


def draw_all(names: list, draw, done=None, helper: bool | None = None, meanwhile=None) -> list:
    """``[draw(name) for name in names]``, drawn by this process and a forked helper (module docstring).

    draw : name -> a picklable outcome; an exception other than ``KeyboardInterrupt`` it raises in the helper makes
    this process draw that plot again (and raise it). done : called with each name once its outcome is known, in
    no particular order (a progress bar), or None. helper : fork one (None: when ``can_fork`` and two or more
    names). meanwhile : called once in this process before it takes a plot, once the helper has started (the
    output files that need no plot: this process writes them while the helper draws, instead of the helper
    waiting for this process's last plot and the files after it), or None."""
    if helper is None:
        helper = len(names) > 1 and can_fork()
    if not helper:
        return _serially(names, draw, done, meanwhile)
    ctx = multiprocessing.get_context("fork")
    try:
        counter = ctx.Array("i", [0, len(names)])  # [next from the start, one past the next from the end]; a
        # semaphore guards it: /dev/shm, which a container may lack
        receive, send = ctx.Pipe(duplex=False)
        process = ctx.Process(target=_helper, args=(names, draw, counter, send), name="e2esim-plots", daemon=True)
        process.start()
    except OSError:  # no helper to be had: drawn here
        return _serially(names, draw, done, meanwhile)
    send.close()  # this process's copy: the pipe ends when the helper's end closes
    outcomes: dict = {}
    try:
        if meanwhile is not None:
            meanwhile()
        while (i := _take(counter, from_end=False)) is not None:
            outcomes[i] = _drawn(draw, names[i], done)
        for i, outcome in _received(receive):
            if outcome != _FAILED:
                outcomes[i] = outcome
                if done is not None:
                    done(names[i])
        process.join()
        # a plot the helper could not draw, or took and did not report (it died): drawn here, errors raised here
        return [outcomes[i] if i in outcomes else _drawn(draw, names[i], done) for i in range(len(names))]
    finally:
        if process.is_alive():  # this process was stopped (Ctrl-C, an error): the helper goes with it
            process.kill()
            process.join()
        receive.close()


def _serially(names: list, draw, done, meanwhile) -> list:
    if meanwhile is not None:
        meanwhile()
    return [_drawn(draw, name, done) for name in names]


def _drawn(draw, name, done):
    outcome = draw(name)
    if done is not None:
        done(name)
    return outcome


def _take(counter, from_end: bool) -> int | None:
    """The index of the next plot nobody has taken, from the start or the end of the list, or None."""
    with counter.get_lock():
        start, end = counter[0], counter[1]
        if start >= end:
            return None
        if from_end:
            counter[1] = end - 1
            return end - 1
        counter[0] = start + 1
        return start


def _received(receive):
    """(index, outcome) of each plot the helper drew, until it is done or gone."""
    while True:
        try:
            message = receive.recv()
        except (EOFError, OSError):  # the helper died: what it did not report is drawn here
            return
        if message is _DONE:
            return
        yield message


def _helper(names, draw, counter, send) -> None:
    """In the forked helper: draw the plots nobody has taken, send each outcome, then ``_DONE``. It ends quietly
    when stopped (Ctrl-C reaches the whole process group: this process's parent handles it)."""
    with contextlib.suppress(BaseException):
        while (i := _take(counter, from_end=True)) is not None:
            try:
                outcome = draw(names[i])
            except Exception:  # drawn again by the parent, which raises it
                outcome = _FAILED
            send.send((i, outcome))
        send.send(_DONE)
    send.close()
