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

A per-call bound is paid on every call, so it must cost little beside a small model's own call
(a tiny ONNX model runs in ~10-30 us); each module below says how its bound does that.

The bounds, by module (every name below is importable from here):
- limits_config.py: ModelLimits, `set_limits`, `limits` (the bounds in force), `bound_text`;
- limits_watchdog.py: `onnx_deadline`, the one watchdog thread per process that stops ONNX runs;
- limits_signal.py: `python_deadline`, SIGALRM on the main thread for Python models;
- limits_project_work.py: `project_work`, the testbed's own work not counted against a bound;
- here: `vet_in_child`, the load-time bound (a child process under load_timeout_s and
  memory_bytes, its clock paused while the testbed's own work runs).
"""

from __future__ import annotations

import dataclasses
import json
import os
import signal
import subprocess
import sys
import time

from learned_contact.errors import WeightsError
from learned_contact.predictors.limits_config import ENVIRONMENT, FLAGS, GiB, ModelLimits, bound_text, limits, set_limits
from learned_contact.predictors.limits_project_work import (
    CLOCK_ENVIRONMENT,
    GO_ON,
    PAUSE,
    PROJECT_WORK_S,
    READY,
    project_work,
    report_clock_to,
    start_clock,
)
from learned_contact.predictors.limits_signal import python_deadline
from learned_contact.predictors.limits_watchdog import onnx_deadline, watchdog_thread

__all__ = ["CLOCK_ENVIRONMENT", "ENVIRONMENT", "FLAGS", "GO_ON", "GiB", "PAUSE", "POLL_S", "PROJECT_WORK_S", "READY", "ModelLimits",
           "bound_text", "limits", "onnx_deadline", "project_work", "python_deadline", "report_clock_to", "set_limits",
           "start_clock", "vet_in_child", "watchdog_thread"]

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
    payload = json.dumps(dataclasses.asdict(limits()))
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
            if peak > limits().memory_bytes:
                why = f"its load-time probe used more than {bound_text('memory_bytes')} of memory"
            elif clock.model_s > limits().load_timeout_s:
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
