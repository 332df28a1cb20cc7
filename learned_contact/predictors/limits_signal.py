"""The per-call bound on Python models (`python_deadline`).

SIGALRM from a one-shot interval timer (setitimer), armed per call on the main
thread, as before: the handler raises in the model's own Python code (a BaseException its
`except Exception` does not swallow) and interrupts a sleep. It is installed and restored
through the C-level signal functions (the `signal` module's wrappers convert handlers to
enums, 5 us per call); a watchdog thread would still need the signal to interrupt the main
thread, so it would add a thread and save nothing.
"""

from __future__ import annotations

import _signal  # the C functions behind `signal`: handlers installed and restored as they are, in ~0.4 us
import signal
import threading
import time

from learned_contact.predictors.limits_config import limits, stopped_error


class _Alarm(BaseException):
    """Raised in the model's Python code by SIGALRM (BaseException: a model's `except
    Exception` does not swallow it)."""


_alarm_armed = False  # a Python bound is armed on the main thread (the handler raises only then)


def _on_alarm(signum, frame):
    if _alarm_armed:
        raise _Alarm()


class _PythonBound:
    __slots__ = ("source", "bound", "what", "calls", "active", "previous", "outer", "start")

    def __init__(self, source: str, bound: str, what: str, calls: int):
        self.source, self.bound, self.what, self.calls, self.active = source, bound, what, calls, False

    def __enter__(self):
        global _alarm_armed
        if threading.current_thread() is not threading.main_thread() or not hasattr(signal, "setitimer"):
            return self
        self.active, self.start = True, time.monotonic()
        self.previous = (_alarm_armed, _signal.signal(signal.SIGALRM, _on_alarm))
        _alarm_armed = True
        self.outer = signal.setitimer(signal.ITIMER_REAL, self.calls * getattr(limits(), self.bound))
        return self

    def __exit__(self, kind, value, traceback):
        global _alarm_armed
        if not self.active:
            return False
        was_armed, handler = self.previous
        _alarm_armed = was_armed
        signal.setitimer(signal.ITIMER_REAL, 0)
        _signal.signal(signal.SIGALRM, handler if handler is not None else signal.SIG_DFL)
        if self.outer[0] > 0:  # an outer timer (another bound) keeps running, less the time spent here
            signal.setitimer(signal.ITIMER_REAL, max(1e-6, self.outer[0] - (time.monotonic() - self.start)),
                             self.outer[1])
        if kind is _Alarm:
            raise stopped_error(self.source, self.what, self.bound, self.calls) from None
        return False


def python_deadline(source: str, bound: str = "call_timeout_s", what: str = "one call", calls: int = 1) -> _PythonBound:
    """A context that interrupts Python code running longer than calls x the bound `bound` (a
    ModelLimits field, [s]; calls > 1: a round of that many calls in a row, bounded as a whole;
    SIGALRM, only on the main thread, where signals are delivered; elsewhere no bound):
    PredictorTimeoutError saying `what` took too long."""
    return _PythonBound(source, bound, what, calls)


def python_bound_armed() -> bool:
    """Whether a Python bound is armed on the main thread now (project_work pauses it)."""
    return _alarm_armed
