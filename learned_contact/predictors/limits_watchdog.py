"""The per-call bound on ONNX models: one watchdog thread per process stops runs past their
deadline (`onnx_deadline`).

onnxruntime's run is one C call that releases the GIL, so no Python signal handler can
run inside it; only another thread can set its RunOptions.terminate. Through 0.6.0 each call
started a `threading.Timer` (a new thread per call: ~260 us per call here, p90 in the ms
on a busy machine, more than the tiny model itself). Now one long-lived daemon thread per
process (`_Watchdog`) serves every call: a call arms it with its run options and deadline
(a lock, a dict entry, no thread, no wake-up of the watchdog in the common case) and disarms
it when the run returns; the watchdog sleeps until the earliest armed deadline and sets
that run's terminate flag when it passes. It is woken only when a call's deadline is earlier
than the time it already sleeps until (the first call after it went idle, or a lowered
bound), so while calls keep coming it wakes about once per call_timeout_s. One per process
(not one per predictor): one thread whatever the number of models; a forked child starts
its own on its first call. `python -m learned_contact.evaluation.bound_cost` measures what
each way adds per call, side by side.
"""

from __future__ import annotations

import math
import os
import threading
import time

from learned_contact.predictors.limits_config import limits, stopped_error


class _Run:
    """One armed ONNX run: its deadline [s, time.monotonic], its RunOptions, whether the
    watchdog stopped it."""

    __slots__ = ("deadline", "options", "fired")

    def __init__(self, deadline: float, options):
        self.deadline, self.options, self.fired = deadline, options, False


class _Watchdog:
    """The one thread per process that stops ONNX runs past their deadline (module docstring).

    arm(options, seconds) -> run; disarm(run) -> whether it was stopped. The thread is started
    by the first arm, sleeps until the earliest armed deadline (`_until`, time.monotonic [s];
    inf: nothing to wait for) and is woken by an arm only when that run's deadline is earlier.
    With nothing armed it keeps its last target once more (`linger`), so a run of calls that
    each arm and disarm within it wakes it about once per bound, not once per call."""

    def __init__(self):
        self._lock = threading.Lock()
        self._wake = threading.Condition(self._lock)
        self._armed: dict[int, _Run] = {}
        self._until = math.inf
        self._thread: threading.Thread | None = None

    def arm(self, options, seconds: float) -> _Run:
        run = _Run(time.monotonic() + seconds, options)
        with self._lock:
            self._armed[id(run)] = run
            if self._thread is None:
                self._thread = threading.Thread(target=self._loop, name="testbed-model-watchdog", daemon=True)
                self._thread.start()
            if run.deadline < self._until:
                self._until = run.deadline
                self._wake.notify()
        return run

    def disarm(self, run: _Run) -> bool:
        with self._lock:
            self._armed.pop(id(run), None)
        return run.fired

    def _loop(self) -> None:
        linger = False
        with self._lock:
            while True:
                now = time.monotonic()
                earliest = math.inf
                for run in self._armed.values():
                    if run.fired:
                        continue
                    if run.deadline <= now:
                        run.fired = True
                        run.options.terminate = True  # onnxruntime stops the run at its next node
                    else:
                        earliest = min(earliest, run.deadline)
                if earliest == math.inf and not linger:
                    linger, earliest = True, now + limits().call_timeout_s  # idle once more before sleeping
                elif earliest != math.inf:
                    linger = False
                self._until = earliest
                self._wake.wait(None if earliest == math.inf else earliest - now)


_watchdog = _Watchdog()


def watchdog_thread() -> threading.Thread | None:
    """The process's watchdog thread (None before the first bounded ONNX call)."""
    return _watchdog._thread


class _OnnxBound:
    __slots__ = ("options", "source", "calls", "what", "run")

    def __init__(self, options, source: str, calls: int, what: str):
        self.options, self.source, self.calls, self.what = options, source, calls, what
        self.run: _Run | None = None

    def __enter__(self):
        self.run = _watchdog.arm(self.options, self.calls * limits().call_timeout_s)
        return self

    def __exit__(self, kind, value, traceback):
        fired = _watchdog.disarm(self.run) if self.run is not None else False
        self.options.terminate = False
        if fired and kind is not None and issubclass(kind, Exception):  # onnxruntime's own error for the flag
            raise stopped_error(self.source, self.what, "call_timeout_s", self.calls) from None
        return False


def onnx_deadline(run_options, source: str, calls: int = 1, what: str = "one call") -> _OnnxBound:
    """A context for onnxruntime runs given `run_options`: the process's watchdog sets its
    terminate flag after calls x call_timeout_s [s] (no thread per call; calls > 1: a round of
    that many runs in a row, bounded as a whole); PredictorTimeoutError naming `source` and
    saying `what` took too long when that stopped a run (a run that returned keeps its answer)."""
    return _OnnxBound(run_options, source, calls, what)


def _after_fork() -> None:
    """In a forked child: a watchdog of its own (the parent's thread does not exist here and its
    lock may be held)."""
    global _watchdog
    _watchdog = _Watchdog()


os.register_at_fork(after_in_child=_after_fork)
