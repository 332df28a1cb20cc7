"""Wall-time watchdog for simulations: a run that stops advancing is stopped, with an
error naming the simulated time and the last system that ran.

A C++ call that spins may hold the GIL, so no Python thread or signal handler of the
simulating process can be relied on to notice. The simulation therefore runs in a
forked child process (it inherits the built diagram; nothing is pickled on the way in).
After every simulator step the child's monitor writes the simulated time into shared
memory; the parent polls it. If it does not change for `stall_timeout` seconds of wall
time, the parent sends SIGUSR1, on which the child's `faulthandler` (C code that needs
no GIL) dumps the Python stacks to a file, then kills the child with SIGKILL. The most
recent stack frame that belongs to a Python system of the diagram names the system
(`system_methods`); when there is none, the child was inside Drake's own C++ code.

Where fork is unavailable, or the scene serves Meshcat (its server thread does not
survive a fork), the run stays in this process under `faulthandler.dump_traceback_later`
(exit status 1 after printing the stack; no custom message is possible there).
"""

from __future__ import annotations

import faulthandler
import inspect
import multiprocessing
import os
import re
import signal
import sys
import tempfile
import time
import traceback

from testbed.errors import SimulationError, TestbedError
from testbed.progress import progress as progress_bar

POLL_S = 0.05  # [s] parent's polling period
DUMP_WAIT_S = 2.0  # [s] longest wait for the child's stack dump before killing it


class StallError(SimulationError):
    """The simulation made no progress for the allowed wall time (CLI exit status 1)."""


def system_methods(diagram) -> dict:
    """{(real source path, function name): (system name, class name)} for every method of
    every Python-defined system in `diagram` (recursing into sub-diagrams)."""
    out = {}
    stack = [diagram]
    while stack:
        d = stack.pop()
        for system in d.GetSystems():
            if hasattr(system, "GetSystems"):
                stack.append(system)
            for klass in type(system).__mro__:
                if klass.__module__.startswith("pydrake") or klass is object:
                    continue
                try:
                    path = os.path.realpath(inspect.getsourcefile(klass))
                except (TypeError, OSError):
                    continue
                for name, member in vars(klass).items():
                    if inspect.isfunction(member):
                        out.setdefault((path, name), (system.get_name(), type(system).__name__))
    return out


_FRAME = re.compile(r'File "(?P<path>[^"]+)", line (?P<line>\d+) in (?P<func>\S+)')


def last_system(dump: str, methods: dict) -> str:
    """The system whose method is the most recent frame of the main thread's stack in a
    faulthandler dump, with the innermost frame; or a sentence saying none was found."""
    block = dump.split("\n\n")
    main = next((b for b in block if "Current thread" in b), dump)  # the thread that was running
    frames = [m.groupdict() for m in _FRAME.finditer(main)]  # most recent first
    if not frames:
        return "unknown (no stack could be read from the stopped process)"
    inner = frames[0]
    where = f"{os.path.relpath(inner['path'])}:{inner['line']} in {inner['func']}"
    for f in frames:
        hit = methods.get((os.path.realpath(f["path"]), f["func"]))
        if hit:
            return f"{hit[0]} ({hit[1]}.{f['func']}; innermost frame {where})"
    return f"none of the diagram's Python systems: Drake's own C++ (the plant or the simulator), called from {where}"


def _child(work, sim_time, conn, dump_path) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent handles Ctrl-C and stops this process
    with open(dump_path, "w") as dump:
        faulthandler.register(signal.SIGUSR1, file=dump, all_threads=True)

        def report(t: float) -> None:
            sim_time.value = t

        try:
            message = ("ok", work(report))
        except SimulationError as e:
            message = ("simulation", str(e))
        except TestbedError as e:
            message = ("testbed", str(e))
        except BaseException:  # noqa: BLE001 - anything else goes back as text
            message = ("crash", traceback.format_exc())
        conn.send(message)
        conn.close()


def run_watched(scene, work, *, stall_timeout: float, duration: float, progress: bool = False):
    """Runs work(report) -> payload in a forked child and returns the payload.

    report(t) is the child's heartbeat (simulated time [s]); `work` must call it after
    every step. Raises StallError when the reported time stays the same for
    `stall_timeout` seconds of wall time before reaching t0 + duration, SimulationError
    when the child fails or dies.
    """
    if not stall_timeout > 0:
        raise TestbedError(f"stall timeout: expected a positive number of seconds, got {stall_timeout}")
    if "fork" not in multiprocessing.get_all_start_methods() or not all(e.forkable for e in scene.effects.values()):
        return _run_here(work, stall_timeout)
    name = scene.scenario.name
    methods = system_methods(scene.diagram)
    ctx = multiprocessing.get_context("fork")
    sim_time = ctx.RawValue("d", float("nan"))
    receive, send = ctx.Pipe(duplex=False)
    fd, dump_path = tempfile.mkstemp(prefix="testbed-stack-", suffix=".txt")
    os.close(fd)
    process = ctx.Process(target=_child, args=(work, sim_time, send, dump_path), daemon=True)
    bar = None
    try:
        process.start()
        send.close()
        if progress:

            bar = progress_bar(total=round(duration, 9), unit="sim s", desc=name, leave=False,
                       bar_format="{l_bar}{bar}| {n:.2f}/{total:.2f} sim s [{elapsed}<{remaining}]")
        seen, changed, t_start = sim_time.value, time.monotonic(), None
        while True:
            if receive.poll(POLL_S):
                try:
                    kind, data = receive.recv()
                except EOFError:
                    raise SimulationError(
                        f"scene '{name}': the simulation process died (exit status {process.exitcode}) "
                        f"at t = {sim_time.value:.4f} s") from None
                break
            now, t = time.monotonic(), sim_time.value
            if t != seen and not (t != t and seen != seen):  # changed (NaN = not started yet)
                seen, changed = t, now
                t_start = t if t_start is None else t_start
                if bar is not None:
                    bar.n = round(t - t_start, 9)
                    bar.refresh()
            finished = t_start is not None and t >= t_start + duration - 1e-9  # collecting records
            if now - changed > stall_timeout and not finished:
                where = _stop(process, dump_path, methods)
                at = "before the first step (in Initialize)" if t != t else f"at simulated t = {t:.4f} s"
                raise StallError(
                    f"scene '{name}': no progress for {stall_timeout:g} s of wall time {at}; "
                    f"last system that ran: {where}; the run was stopped and nothing was written")
            if not process.is_alive() and not receive.poll(0):
                raise SimulationError(
                    f"scene '{name}': the simulation process died (exit status {process.exitcode}) "
                    f"at t = {sim_time.value:.4f} s")
    finally:
        if bar is not None:
            bar.close()
        if process.is_alive():
            process.kill()
        if process.pid is not None:
            process.join()
        receive.close()
        os.unlink(dump_path)
    if kind == "ok":
        return data
    if kind == "simulation":
        raise SimulationError(data)
    if kind == "testbed":
        raise TestbedError(data)
    raise SimulationError(f"scene '{name}': the simulation process raised:\n{data}")


def _stop(process, dump_path: str, methods: dict) -> str:
    """Dumps the child's stacks (SIGUSR1), kills it, returns the last system that ran."""
    try:
        os.kill(process.pid, signal.SIGUSR1)
    except ProcessLookupError:
        pass
    deadline = time.monotonic() + DUMP_WAIT_S
    dump = ""
    while time.monotonic() < deadline:
        time.sleep(POLL_S)
        with open(dump_path) as f:
            dump = f.read()
        if _FRAME.search(dump):
            time.sleep(POLL_S)  # let the dump finish
            with open(dump_path) as f:
                dump = f.read()
            break
    process.kill()
    process.join()
    return last_system(dump, methods)


def _run_here(work, stall_timeout: float):
    """No fork (or Meshcat): run in this process; faulthandler's C watchdog thread prints
    the stacks and exits with status 1 if the heartbeat stops for stall_timeout [s]."""
    armed = [0.0]

    def report(_t: float) -> None:
        now = time.monotonic()
        if now - armed[0] > 0.25 * stall_timeout:  # re-arm at most 4 times per timeout
            faulthandler.dump_traceback_later(stall_timeout, exit=True, file=sys.stderr)
            armed[0] = now

    try:
        return work(report)
    finally:
        faulthandler.cancel_dump_traceback_later()
