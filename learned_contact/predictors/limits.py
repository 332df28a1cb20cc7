"""Bounds on a model the testbed did not ship (ONNX files, `module:attribute` Python models).

A user's model is untrusted: it may hang, allocate without end or be huge. Every such model
runs under `ModelLimits` (the command line sets them with --model-load-timeout,
--model-call-timeout, --model-memory and --model-max-nodes on every command; the Python API
with `set_limits`):

- load_timeout_s [s]: loading the model and its load-time probe (learned_contact.vet) run
  first in a child process (`vet_in_child`), killed when it takes longer; the model is then
  loaded in this process only if the child accepted it;
- memory_bytes: the child is killed when its resident memory passes this, and an ONNX model's
  file plus its external data files may not be larger than it (checked before onnxruntime
  reads anything);
- max_nodes: an ONNX graph, its subgraphs (Loop, If, Scan bodies) counted, may hold at most
  this many nodes (the session's build time grows with them: 250,000 chained nodes took
  42-55 s here);
- call_timeout_s [s]: each call of the model in this process: an ONNX run is stopped through
  onnxruntime's RunOptions.terminate, Python code by SIGALRM (main thread only; elsewhere the
  bound applies to ONNX models alone). A stopped call raises PredictorTimeoutError naming the
  model and the bound.

Each bound exceeded is one line (WeightsError at load, PredictorTimeoutError per call) that
names the model, the bound and its flag.

How a call is bounded, and what that costs (issue 37). A bound is paid on every call, so it
must cost little beside a small model's own call (a tiny ONNX model runs in ~10-30 us):

- ONNX: onnxruntime's run is one C call that releases the GIL, so no Python signal handler can
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
- Python: SIGALRM from a one-shot interval timer (setitimer), armed per call on the main
  thread, as before: the handler raises in the model's own Python code (a BaseException its
  `except Exception` does not swallow) and interrupts a sleep. It is installed and restored
  through the C-level signal functions (the `signal` module's wrappers convert handlers to
  enums, 5 us per call); a watchdog thread would still need the signal to interrupt the main
  thread, so it would add a thread and save nothing.

The project's own work is never counted against a bound (`project_work`): a user's model may
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

import _signal  # the C functions behind `signal`: handlers installed and restored as they are, in ~0.4 us
import contextlib
import dataclasses
import json
import math
import os
import signal
import subprocess
import sys
import threading
import time

from learned_contact.errors import PredictorTimeoutError, WeightsError

GiB = 1 << 30


@dataclasses.dataclass(frozen=True)
class ModelLimits:
    """The bounds every untrusted model runs under (see the module docstring)."""

    load_timeout_s: float = 30.0  # [s] the shipped model's ONNX export loads and probes in ~1 s here
    call_timeout_s: float = 10.0  # [s] one call; the shipped model answers 1,000 poses in ~15 ms
    memory_bytes: int = 2 * GiB  # resident memory of the vetting child; model file + external data
    max_nodes: int = 20_000  # ONNX nodes with subgraphs; the shipped improved export has 2,368 (issue 30: with the quadrature)


FLAGS = {"load_timeout_s": "--model-load-timeout", "call_timeout_s": "--model-call-timeout",
         "memory_bytes": "--model-memory", "max_nodes": "--model-max-nodes"}
# set_limits writes the bounds here as JSON so that worker processes (validate's process pool,
# bench and vetting children) start with them
ENVIRONMENT = "TESTBED_MODEL_LIMITS"


def _from_environment() -> ModelLimits:
    try:
        given = {k: v for k, v in json.loads(os.environ.get(ENVIRONMENT, "{}")).items() if k in FLAGS}
        if not all(isinstance(v, (int, float)) and 0 < v < float("inf") for v in given.values()):
            return ModelLimits()
        return dataclasses.replace(ModelLimits(), **given)
    except (ValueError, TypeError, AttributeError):
        return ModelLimits()


_limits = _from_environment()


def limits() -> ModelLimits:
    """The bounds in force (process-wide)."""
    return _limits


def set_limits(**changes) -> ModelLimits:
    """Changes some bounds (ModelLimits field names); returns the bounds now in force. Each
    value must be positive; raises WeightsError naming the flag otherwise."""
    global _limits
    for name, value in changes.items():
        if name not in FLAGS:
            raise WeightsError(f"unknown model limit {name!r}; expected one of {sorted(FLAGS)}")
        if not (isinstance(value, (int, float)) and value > 0 and value == value and value != float("inf")):
            raise WeightsError(f"{FLAGS[name]} {value!r}: expected a positive finite number")
    _limits = dataclasses.replace(_limits, **changes)
    os.environ[ENVIRONMENT] = json.dumps(dataclasses.asdict(_limits))
    return _limits


def bound_text(name: str) -> str:
    """'10 s (--model-call-timeout)' for one bound."""
    value = getattr(_limits, name)
    text = f"{value / GiB:.3g} GiB" if name == "memory_bytes" else f"{value:g} s" if name.endswith("_s") else f"{value:g}"
    return f"{text} ({FLAGS[name]})"


def _stopped(source: str, what: str, bound: str, calls: int = 1) -> PredictorTimeoutError:
    limit = bound_text(bound) if calls == 1 else f"{calls * getattr(_limits, bound):g} s ({calls} x {FLAGS[bound]})"
    return PredictorTimeoutError(f"{source}: {what} took longer than {limit} and was stopped; "
                                 "expected an answer within the bound")


# ----------------------------------------------------------------------------- per call: ONNX

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
                    linger, earliest = True, now + _limits.call_timeout_s  # idle once more before sleeping
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
        self.run = _watchdog.arm(self.options, self.calls * _limits.call_timeout_s)
        return self

    def __exit__(self, kind, value, traceback):
        fired = _watchdog.disarm(self.run) if self.run is not None else False
        self.options.terminate = False
        if fired and kind is not None and issubclass(kind, Exception):  # onnxruntime's own error for the flag
            raise _stopped(self.source, self.what, "call_timeout_s", self.calls) from None
        return False


def onnx_deadline(run_options, source: str, calls: int = 1, what: str = "one call") -> _OnnxBound:
    """A context for onnxruntime runs given `run_options`: the process's watchdog sets its
    terminate flag after calls x call_timeout_s [s] (no thread per call; calls > 1: a round of
    that many runs in a row, bounded as a whole); PredictorTimeoutError naming `source` and
    saying `what` took too long when that stopped a run (a run that returned keeps its answer)."""
    return _OnnxBound(run_options, source, calls, what)


# ----------------------------------------------------------------------------- per call: Python

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
        self.outer = signal.setitimer(signal.ITIMER_REAL, self.calls * getattr(_limits, self.bound))
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
            raise _stopped(self.source, self.what, self.bound, self.calls) from None
        return False


def python_deadline(source: str, bound: str = "call_timeout_s", what: str = "one call", calls: int = 1) -> _PythonBound:
    """A context that interrupts Python code running longer than calls x the bound `bound` (a
    ModelLimits field, [s]; calls > 1: a round of that many calls in a row, bounded as a whole;
    SIGALRM, only on the main thread, where signals are delivered; elsewhere no bound):
    PredictorTimeoutError saying `what` took too long."""
    return _PythonBound(source, bound, what, calls)


# ----------------------------------------------------------------------------- the project's own work

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
    if _alarm_armed and threading.current_thread() is threading.main_thread():
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
    """In a forked child: a watchdog of its own (the parent's thread does not exist here and its
    lock may be held), no project work under way, and no word to a vetting parent (the process
    forked from a vetting child does not speak for it)."""
    global _watchdog, _project_lock, _project_depth, _clock_fd
    _watchdog = _Watchdog()
    _project_lock, _project_depth, _clock_fd = threading.Lock(), 0, None


os.register_at_fork(after_in_child=_after_fork)


# ----------------------------------------------------------------------------- at load

POLL_S = 0.02  # [s] how often the parent reads the child's resident memory and its clock messages


def _rss(pid: int) -> int:
    """Resident memory [bytes] of a process (0 when it has gone)."""
    try:
        with open(f"/proc/{pid}/status", encoding="ascii") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError):
        pass
    return 0


class _ChildClock:
    """The parent's clock of a vetting child [s]: `model_s` counts the time after the child's
    READY outside its PAUSE..GO_ON spans, `own_s` the rest (its own start-up, the project's
    work). Read every POLL_S, so each change of state is placed within POLL_S."""

    def __init__(self, fd: int):
        self.fd, self.counting, self.paused = fd, False, False
        self.model_s = self.own_s = 0.0
        self.last = time.monotonic()

    def tick(self) -> None:
        now = time.monotonic()
        if self.counting and not self.paused:
            self.model_s += now - self.last
        else:
            self.own_s += now - self.last
        self.last = now
        try:
            messages = os.read(self.fd, 4096)
        except (BlockingIOError, InterruptedError):
            return
        for byte in messages:
            self.counting |= byte == READY[0]
            if byte in (PAUSE[0], GO_ON[0]):
                self.paused = byte == PAUSE[0]


def vet_in_child(spec: str) -> None:
    """Loads and probes the model `spec` in a child process under load_timeout_s and
    memory_bytes (learned_contact.vet); WeightsError with the child's one line, or naming
    the bound the child passed. The child sees this process's sys.path and working directory.
    The load clock counts the model's own time: it starts when the child has imported the
    testbed and stops while the testbed's own work runs (project_work), which may take up to
    PROJECT_WORK_S [s] in all."""
    read_fd, write_fd = os.pipe()
    os.set_blocking(read_fd, False)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in sys.path if p), CLOCK_ENVIRONMENT: str(write_fd)}
    payload = json.dumps(dataclasses.asdict(_limits))
    try:
        proc = subprocess.Popen([sys.executable, "-m", "learned_contact.vet", spec, payload], stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, stdin=subprocess.DEVNULL, env=env, text=True,
                                pass_fds=(write_fd,))
    finally:
        os.close(write_fd)
    clock, peak, why = _ChildClock(read_fd), 0, None
    try:
        while proc.poll() is None:
            peak = max(peak, _rss(proc.pid))
            clock.tick()
            if peak > _limits.memory_bytes:
                why = f"its load-time probe used more than {bound_text('memory_bytes')} of memory"
            elif clock.model_s > _limits.load_timeout_s:
                why = f"loading and probing it took longer than {bound_text('load_timeout_s')}"
            elif clock.own_s > PROJECT_WORK_S:
                why = (f"the testbed's own start-up and kernels in the process vetting it took longer than "
                       f"{PROJECT_WORK_S:g} s (the testbed's time, not counted against "
                       f"{bound_text('load_timeout_s')})")
            if why:
                proc.kill()
                break
            time.sleep(POLL_S)
        out, err = proc.communicate()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
        os.close(read_fd)
    if why:
        raise WeightsError(f"model {spec}: refused: {why}; it was stopped")
    if proc.returncode == 0:
        return
    lines = [ln for ln in (out or "").splitlines() if ln.startswith("refused: ")]
    if lines:
        try:
            message = json.loads(lines[-1][len("refused: "):])
        except ValueError:
            message = None
        if isinstance(message, str):
            raise WeightsError(message)
    if proc.returncode < 0:
        sig = signal.Signals(-proc.returncode).name if -proc.returncode in signal.valid_signals() else proc.returncode
        raise WeightsError(f"model {spec}: refused: the process loading it was killed by {sig} "
                           "(a crash or an abort in the model's code)")
    tail = [ln for ln in (err or "").strip().splitlines() if ln.strip()]
    raise WeightsError(f"model {spec}: refused: loading it ended with exit status {proc.returncode}"
                       + (f" ({tail[-1][:200]})" if tail else " and no message"))
