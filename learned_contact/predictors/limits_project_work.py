"""The project's own work is never counted against a model's bound (`project_work`): a user's model may
load the shipped predictor (testbed.validation.sensitivity's models do), and loading it the
first time in a process (reading its weights, loading or compiling its kernels: 57-73 s of
numba compilation in a fresh clone on a busy machine) is the testbed's cost, not the model's.
learned_contact.sources.load_predictor loads and warms the shipped kinds inside
`project_work`, which pauses the SIGALRM bound of the call it runs in and, in the vetting
child, the parent's load clock; the child also starts that clock only once its own imports
are done. The pause is capped at PROJECT_WORK_S in the child (a wedged start-up is stopped and
said to be the testbed's own).
"""

from __future__ import annotations

import contextlib
import os
import signal
import threading

from learned_contact.predictors.limits_signal import python_bound_armed

PROJECT_WORK_S = 600.0  # [s] the most the vetting child may spend on the testbed's own start-up and kernels
CLOCK_ENVIRONMENT = "TESTBED_VET_CLOCK_FD"  # the pipe on which a vetting child tells its parent's clock
READY, PAUSE, GO_ON = b"r", b"p", b"c"  # the child's messages: own imports done; project work begins; ends

_clock_fd: int | None = None  # in a vetting child: the pipe to the parent
_project_depth = 0
_project_lock = threading.Lock()


def _tell(message: bytes) -> None:
    if _clock_fd is not None:
        try:
            os.write(_clock_fd, message)
        except OSError:  # the parent has gone: nothing to tell
            pass


def report_clock_to(fd: int) -> None:
    """In a vetting child: say to the parent on pipe `fd` when its load clock starts (`start_clock`)
    and when the project's own work pauses it (`project_work`)."""
    global _clock_fd
    os.set_inheritable(fd, False)  # a process the model starts does not speak for this one
    _clock_fd = fd


def start_clock() -> None:
    """In a vetting child: the testbed's own imports are done; the model's load clock starts."""
    _tell(READY)


@contextlib.contextmanager
def project_work():
    """The testbed's own work (loading the shipped predictor, reading or compiling its kernels)
    when it runs inside a model's bound: not counted against it. On the main thread, a Python
    model's SIGALRM bound is paused and re-armed with what was left; in a vetting child, the
    parent's load clock is paused. Nests (the outermost pauses)."""
    global _project_depth
    with _project_lock:
        _project_depth += 1
        if _project_depth == 1:
            _tell(PAUSE)
    paused = None
    if python_bound_armed() and threading.current_thread() is threading.main_thread():
        paused = signal.setitimer(signal.ITIMER_REAL, 0)  # (left, interval); (0, 0) when already paused
    try:
        yield
    finally:
        if paused is not None and paused[0] > 0:
            signal.setitimer(signal.ITIMER_REAL, *paused)
        with _project_lock:
            _project_depth -= 1
            if _project_depth == 0:
                _tell(GO_ON)



def _after_fork() -> None:
    """In a forked child: no project work under way, and no word to a vetting parent (the process
    forked from a vetting child does not speak for it)."""
    global _project_lock, _project_depth, _clock_fd
    _project_lock, _project_depth, _clock_fd = threading.Lock(), 0, None


os.register_at_fork(after_in_child=_after_fork)
