"""Bounds on a model the testbed did not ship (ONNX files, `module:attribute` Python models).

A user's model is untrusted: it may hang, allocate without end or be huge. Every such model
runs under `ModelLimits` (the command line sets them with --model-load-timeout,
--model-call-timeout, --model-memory and --model-max-nodes on every command; the Python API
with `set_limits`):

- load_timeout_s [s]: loading the model and its load-time probe (learned_contact.probe) run
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
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
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


# ----------------------------------------------------------------------------- per call

@contextlib.contextmanager
def onnx_deadline(run_options, source: str):
    """Stops an onnxruntime run given `run_options` after call_timeout_s: sets its
    terminate flag from a timer thread; PredictorTimeoutError when that happened."""
    fired = threading.Event()

    def stop():
        fired.set()
        run_options.terminate = True

    timer = threading.Timer(_limits.call_timeout_s, stop)
    timer.daemon = True
    timer.start()
    try:
        yield
    except Exception:  # noqa: BLE001 - onnxruntime's own error when the flag stopped it
        if fired.is_set():
            raise PredictorTimeoutError(f"{source}: one call took longer than {bound_text('call_timeout_s')} "
                                        "and was stopped; expected an answer within the bound") from None
        raise
    finally:
        timer.cancel()
        run_options.terminate = False


class _Alarm(BaseException):
    """Raised in the model's Python code by SIGALRM (BaseException: a model's `except
    Exception` does not swallow it)."""


@contextlib.contextmanager
def python_deadline(source: str, bound: str = "call_timeout_s", what: str = "one call"):
    """Interrupts Python code that runs longer than the bound `bound` (a ModelLimits field;
    SIGALRM, only on the main thread, where signals are delivered; elsewhere no bound):
    PredictorTimeoutError saying `what` took too long."""
    if threading.current_thread() is not threading.main_thread() or not hasattr(signal, "setitimer"):
        yield
        return

    def on_alarm(signum, frame):
        raise _Alarm()

    previous = signal.signal(signal.SIGALRM, on_alarm)
    old_timer = signal.setitimer(signal.ITIMER_REAL, getattr(_limits, bound))
    try:
        yield
    except _Alarm:
        raise PredictorTimeoutError(f"{source}: {what} took longer than {bound_text(bound)} and was "
                                    "stopped; expected an answer within the bound") from None
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
        if old_timer[0] > 0:  # an outer timer (another bound) keeps running
            signal.setitimer(signal.ITIMER_REAL, *old_timer)


# ----------------------------------------------------------------------------- at load

POLL_S = 0.02  # [s] how often the parent reads the child's resident memory


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


def vet_in_child(spec: str) -> None:
    """Loads and probes the model `spec` in a child process under load_timeout_s and
    memory_bytes (learned_contact.vet); WeightsError with the child's one line, or naming
    the bound the child passed. The child sees this process's sys.path and working directory."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in sys.path if p)}
    payload = json.dumps(dataclasses.asdict(_limits))
    proc = subprocess.Popen([sys.executable, "-m", "learned_contact.vet", spec, payload], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, stdin=subprocess.DEVNULL, env=env, text=True)
    start, peak, why = time.monotonic(), 0, None
    try:
        while proc.poll() is None:
            peak = max(peak, _rss(proc.pid))
            if peak > _limits.memory_bytes:
                why = f"its load-time probe used more than {bound_text('memory_bytes')} of memory"
            elif time.monotonic() - start > _limits.load_timeout_s:
                why = f"loading and probing it took longer than {bound_text('load_timeout_s')}"
            if why:
                proc.kill()
                break
            time.sleep(POLL_S)
        out, err = proc.communicate()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
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
