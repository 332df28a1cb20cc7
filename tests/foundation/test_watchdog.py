"""`testbed run`'s watchdog: a run whose simulated time stops advancing is stopped with
an error naming the simulated time and the last system that ran, exit status 1, and
nothing written; a healthy run under the watchdog gives the same records as in-process.

The hang is a LeafSystem that, from t = 20 ms on, calls libc's sleep through
ctypes.PyDLL, which keeps the GIL held: like a C++ query that spins, no Python thread
or Python signal handler of that process can run. Each hang test takes ~stall + 1 s.
"""

import ctypes
import re
import time

import numpy as np
import pytest
from pydrake.systems.framework import LeafSystem

from testbed import build_scene, load_scenario
from testbed.effects import wind
from testbed.simulation import simulate
from testbed.watchdog import StallError

HANG_AT = 0.02  # [s] simulated time at which the probe hangs
STALL = 2.0  # [s] wall time allowed without progress


class HangProbe(LeafSystem):
    """Publishes every plant step; from HANG_AT on, blocks in C with the GIL held."""

    def __init__(self, assembly):
        super().__init__()
        self.set_name("hang_probe")
        self.DeclarePeriodicPublishEvent(assembly.plant.time_step(), 0.0, self._tick)
        assembly.builder.AddSystem(self)

    def _tick(self, context):
        if context.get_time() >= HANG_AT - 1e-9:
            ctypes.PyDLL(None).sleep(60)  # libc sleep(60) without releasing the GIL


@pytest.fixture
def hanging_wind(monkeypatch):
    """The wind effect also adds a HangProbe (the scene schema is fixed at import)."""
    original = wind.WindEffect.add_systems

    def add_systems(self, assembly):
        return list(original(self, assembly)) + [HangProbe(assembly)]

    monkeypatch.setattr(wind.WindEffect, "add_systems", add_systems)


def test_a_hang_holding_the_gil_is_stopped_and_named(hanging_wind):
    scene = build_scene(load_scenario("windy_stack", overrides=["duration=0.2"]))
    start = time.monotonic()
    with pytest.raises(StallError) as info:
        simulate(scene, stall_timeout=STALL)
    elapsed = time.monotonic() - start
    message = str(info.value)
    assert "no progress for 2 s" in message
    # the heartbeat (the simulator's monitor) runs after a step's publish events; the
    # probe hangs in the publish at HANG_AT, so the last time reported is one 1 ms step earlier
    t = float(re.search(r"simulated t = ([0-9.]+) s", message).group(1))
    assert HANG_AT - 1e-3 - 1e-9 <= t <= HANG_AT
    assert "last system that ran: hang_probe (HangProbe._tick" in message
    assert elapsed < STALL + 10.0  # stopped, not left to run its 60 s sleep


def test_cli_exits_1_and_writes_nothing_on_a_hang(hanging_wind, tmp_path, capsys):
    from testbed.cli import main

    out = tmp_path / "run"
    status = main(["run", "windy_stack", "--duration", "0.2", "--out", str(out), "--quiet",
                   "--stall-timeout", str(STALL)])
    assert status == 1
    err = capsys.readouterr().err
    assert "no progress for 2 s" in err and "last system that ran: hang_probe" in err and "simulated t = 0.0" in err
    assert len(err.strip().splitlines()) == 1  # one clear line, no traceback
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []  # no temporary directory left behind either


def test_a_healthy_run_under_the_watchdog_matches_the_in_process_run():
    scenario = load_scenario("single_drop", overrides=["duration=0.05"])
    here = simulate(build_scene(scenario))
    watched = simulate(build_scene(scenario), stall_timeout=30.0)
    np.testing.assert_array_equal(watched.final_positions, here.final_positions)
    for name, table in here.tables.items():
        assert set(watched.tables[name]) == set(table)
        for column, values in table.items():
            np.testing.assert_array_equal(watched.tables[name][column], values)
    assert watched.summary["steps"] == here.summary["steps"]


def test_a_failure_in_the_child_is_a_simulation_error(monkeypatch):
    """A system that raises inside the child comes back as one SimulationError."""
    from testbed.errors import SimulationError

    class Broken(LeafSystem):
        def __init__(self, assembly):
            super().__init__()
            self.set_name("broken_probe")
            self.DeclarePeriodicPublishEvent(assembly.plant.time_step(), 0.0, self._tick)
            assembly.builder.AddSystem(self)

        def _tick(self, context):
            if context.get_time() > 0.01:
                raise RuntimeError("probe failed on purpose")

    original = wind.WindEffect.add_systems
    monkeypatch.setattr(wind.WindEffect, "add_systems", lambda self, a: list(original(self, a)) + [Broken(a)])
    scene = build_scene(load_scenario("windy_stack", overrides=["duration=0.05"]))
    with pytest.raises(SimulationError, match="probe failed on purpose"):
        simulate(scene, stall_timeout=30.0)


def test_in_process_fallback_exits_1_on_a_hang_holding_the_gil(tmp_path):
    """Without fork (or with Meshcat) the run stays in-process: faulthandler's C thread
    prints the stack and ends the process with status 1 even though the GIL is held."""
    import subprocess
    import sys

    code = (
        "import ctypes\n"
        "from testbed.watchdog import _run_here\n"
        "def work(report):\n"
        "    report(0.0)\n"
        "    ctypes.PyDLL(None).sleep(60)\n"
        "_run_here(work, 1.0)\n"
    )
    start = time.monotonic()
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=30)
    assert done.returncode == 1
    assert "Timeout" in done.stderr and "in work" in done.stderr
    assert time.monotonic() - start < 20.0


def test_a_non_positive_stall_timeout_is_bad_input(tmp_path, capsys):
    from testbed.cli import main

    status = main(["run", "defaults", "--out", str(tmp_path / "run"), "--quiet", "--stall-timeout", "0"])
    assert status == 2
    assert "--stall-timeout: expected a positive number of seconds" in capsys.readouterr().err
    assert not (tmp_path / "run").exists()
