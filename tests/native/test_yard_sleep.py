"""The native step's sleeping on a resting yard (native/examples/yard_sleep.c): built by the Makefile,
run on a small yard, every island asleep after t_sleep, its pairs no longer asked, the wrenches unchanged,
and the asleep step cheaper than the awake one timed side by side (a ratio, not a time).

Measured 2026-12-07 (2 shared cores, wall / CPU us per cc_contact_step, best of 7 x 100): 200 boxes
1,846 / 1,395 awake, 1,357 / 1,021 asleep (0.73); 1,000 boxes 10,390 / 7,249 awake, 7,510 / 5,250
asleep (0.72): sleeping saves the predictor's asks, the force law still runs on every pair.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
NATIVE = REPO / "native"
WEIGHTS = REPO / "learned_contact" / "shipped" / "weights.npz"
CC = next((c for c in ("cc", "gcc", "clang") if shutil.which(c)), None)
pytestmark = [pytest.mark.once,  # no Drake in it: suite 2 leaves it to suite 1
              pytest.mark.skipif(CC is None or shutil.which("make") is None, reason="needs a C compiler and make")]


@pytest.fixture(scope="module")
def figures(tmp_path_factory) -> dict[str, list[float]]:
    out = tmp_path_factory.mktemp("yard_sleep")
    done = subprocess.run(["make", "-C", str(NATIVE), f"BUILD={out}", f"CC={CC}", "yard_sleep", "-j2"],
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout + done.stderr
    ran = subprocess.run([str(out / "yard_sleep"), str(WEIGHTS), "50", "-steps", "20"], capture_output=True, text=True,
                         timeout=600)
    assert ran.returncode == 0, ran.stdout + ran.stderr
    return {key: [float(v) for v in values] for key, *values in (line.split() for line in ran.stdout.splitlines())}


def test_every_island_of_the_resting_yard_falls_asleep_and_stops_asking(figures):
    n, stacks, pairs = figures["yard"]
    assert (n, stacks) == (50, 10)
    assert pairs == n  # one candidate per interface: 5 per stack, the lowest on the fixed stand-in
    assert figures["asked"] == [pairs, 0.0]  # awake: every pair asked; asleep: none
    assert figures["bodies_asleep"] == [n]
    assert figures["wrench_rel"] == [0.0]  # a reused answer on the same poses is the same answer


@pytest.mark.timing  # a ratio of clocks: serially, alone on the machine (tests/tiers.py)
def test_the_asleep_step_is_cheaper_than_the_awake_one_side_by_side(figures):
    wall, cpu = figures["ratio"]
    assert figures["asleep_us"][0] < figures["awake_us"][0] and wall < 1.0, figures
    assert cpu < 1.0, figures
