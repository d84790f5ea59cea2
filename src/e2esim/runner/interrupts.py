"""Ctrl-C and stop signals during a run: what they may cut short (the block in flight) and what they may not
(saving a finished block, HDF5 writing a file).

Python turns SIGINT into ``KeyboardInterrupt`` wherever the main thread happens to be; the command line turns
SIGTERM and SIGHUP into ``Stopped``, a ``KeyboardInterrupt`` too (``stop_signals_as_interrupts``), so that every
way of stopping a run ends it the same way: the finished blocks kept, one message, how to resume (the run path,
``e2esim.runner.folder_run``, raises it as ``RunInterrupted``, which the command line prints and ``e2esim.run``
lets through). Inside a
block's computation that is what we want: the block is dropped and the run ends at once. Inside the few
milliseconds that keep a finished block, or while HDF5 writes results.h5 (an exception raised inside HDF5's file
callbacks would leave the library in a state that crashes the interpreter at exit), it is not: there
``interrupts_deferred`` holds the signal back and raises it when the section ends.
"""

from __future__ import annotations

import contextlib
import signal
import threading

_STOP_SIGNALS = tuple(getattr(signal, name) for name in ("SIGTERM", "SIGHUP") if hasattr(signal, name))


class Stopped(KeyboardInterrupt):
    """SIGTERM or SIGHUP during a run (``stop_signals_as_interrupts``); ``signum`` is the signal."""

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


class RunInterrupted(KeyboardInterrupt):
    """A run ended by Ctrl-C or a stop signal: ``message`` says what was kept and how to go on (without the
    ``e2esim:`` prefix); ``exit_status`` is 130 for Ctrl-C, 128 + the signal number for SIGTERM and SIGHUP.
    A ``KeyboardInterrupt``, so that a program calling ``e2esim.run`` is interrupted as Python interrupts it."""

    def __init__(self, stop: KeyboardInterrupt, what: str, when: str = ""):
        if isinstance(stop, Stopped):
            self.message, self.exit_status = f"stopped by {stop}{when}; {what}", 128 + stop.signum
        else:
            self.message, self.exit_status = f"interrupted{when}; {what}", 130
        super().__init__(self.message)


def _raise_stopped(signum, frame):
    raise Stopped(signum)


@contextlib.contextmanager
def stop_signals_as_interrupts():
    """While the body runs (in the main thread), SIGTERM and SIGHUP raise ``Stopped`` where they would have ended
    the process at once (their default action); handlers someone else installed stay."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    replaced = {s: signal.getsignal(s) for s in _STOP_SIGNALS if signal.getsignal(s) == signal.SIG_DFL}
    for signum in replaced:
        signal.signal(signum, _raise_stopped)
    try:
        yield
    finally:
        for signum, previous in replaced.items():
            signal.signal(signum, previous)


class Deferred:
    """The signals held back by ``interrupts_deferred``: ``received`` lists them in the order they came."""

    def __init__(self):
        self.received: list = []
        self.handlers: dict = {}  # {signal: the handler in force before}

    def _hold(self, signum, frame) -> None:
        self.received.append(signum)

    def raise_now(self) -> None:
        """Hand the first signal held back to its handler (which raises), and forget the others."""
        if self.received:
            signum = self.received[0]
            self.received.clear()
            self.handlers[signum](signum, None)


@contextlib.contextmanager
def interrupts_deferred():
    """Hold SIGINT (and SIGTERM, SIGHUP where Python handles them) back while the body runs; when the body ends,
    hand the first that came to the handler that was in force (the default one raises KeyboardInterrupt).

    Only the main thread receives signals; elsewhere (a run started from a thread) this does nothing. A body
    that wants to stop early reads ``Deferred.received`` and calls ``raise_now`` (``e2esim.io.guarded_h5``).
    """
    deferred = Deferred()
    if threading.current_thread() is not threading.main_thread():
        yield deferred
        return
    for signum in (signal.SIGINT, *_STOP_SIGNALS):
        handler = signal.getsignal(signum)
        if callable(handler):  # not SIG_DFL, SIG_IGN or a handler installed outside Python (None)
            deferred.handlers[signum] = handler
            signal.signal(signum, deferred._hold)
    try:
        yield deferred
    finally:
        for signum, handler in deferred.handlers.items():
            signal.signal(signum, handler)
        deferred.raise_now()


def worker_signals() -> None:
    """In a worker process: leave Ctrl-C to the main process, which stops the workers itself (a terminal sends
    SIGINT to every process of the run at once), and let SIGTERM and SIGHUP end the worker at once (a forked worker
    inherits the main process's ``stop_signals_as_interrupts``)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    for signum in _STOP_SIGNALS:
        signal.signal(signum, signal.SIG_DFL)
