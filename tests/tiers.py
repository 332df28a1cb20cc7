"""The test suite's tiers, and the one command that runs them (README's second command, CI's suites).

    python tests/tiers.py                 every tier, one after the other (CI's suite 1)
    python tests/tiers.py --suite 2       the tiers' tests whose answer can differ between Drake
                                          releases (CI's second interpreter, Drake 1.58)
    python tests/tiers.py --tier fast     one tier; arguments after `--` go to every pytest run

A tier is a marker expression over the collected tests, a number of pytest-xdist workers, and the
suites it runs in. The expressions partition the suite (tests/project/test_tiers.py holds them to
it: every collected test runs in exactly one tier of suite 1, and every test not marked `once` in
the same tier of suite 2):

- fast: everything else, in parallel (one worker per core, a file's tests on one worker so that
  the scenes conftest caches per process are simulated once per file);
- slow: the long physics gates and the training reproduction (`@pytest.mark.slow`), in parallel;
- timing: tests that read a clock (`@pytest.mark.timing`: the cost ratios, the fail-fast wall bounds
  on hostile input), serially, alone on the machine, after the parallel tiers.

`@pytest.mark.once` marks a test whose answer cannot differ between Drake releases (lint, the import
contracts, the Ray executor's plumbing): suite 2 leaves it to suite 1. Exit status: 0 when every tier
passed, else the first failing tier's pytest status.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Tier:
    name: str
    marks: str  # pytest -m expression (pyproject's addopts `-m 'not study'` is replaced, so it says so too)
    parallel: bool  # pytest-xdist, one worker per core (files kept whole), or one process
    why: str


TIERS = (
    Tier("fast", "not slow and not timing and not study", True, "every test under a few minutes, in parallel"),
    Tier("slow", "slow and not timing and not study", True, "the long physics gates and the training reproduction"),
    Tier("timing", "timing and not study", False, "tests that read a clock, alone on the machine"),
)
SUITE_2_EXCLUDES = "once"  # marker left to suite 1 (what cannot differ between Drake releases)


def marks_for(tier: Tier, suite: int) -> str:
    """The -m expression a tier runs with in a suite (1: everything; 2: what Drake's version can change)."""
    return tier.marks if suite == 1 else f"({tier.marks}) and not {SUITE_2_EXCLUDES}"


def workers() -> int:
    """pytest-xdist workers for the parallel tiers: TESTBED_TEST_WORKERS, else the usable cores (at least 1)."""
    if os.environ.get("TESTBED_TEST_WORKERS"):
        return max(1, int(os.environ["TESTBED_TEST_WORKERS"]))
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # macOS, Windows
        return max(1, os.cpu_count() or 1)


def command(tier: Tier, suite: int, extra: list[str]) -> list[str]:
    cmd = [sys.executable, "-m", "pytest", "-m", marks_for(tier, suite)]
    n = workers()
    if tier.parallel and n > 1:
        cmd += ["-n", str(n), "--dist", "loadfile"]
    else:
        cmd += ["-p", "no:xdist"]
    return cmd + extra


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--suite", type=int, choices=(1, 2), default=1,
                        help="1: every test (default); 2: leave tests marked `once` to suite 1")
    parser.add_argument("--tier", action="append", choices=[t.name for t in TIERS],
                        help="run only this tier (repeatable); default: all, in order")
    argv = sys.argv[1:] if argv is None else list(argv)
    extra: list[str] = []
    if "--" in argv:
        at = argv.index("--")
        argv, extra = argv[:at], argv[at + 1:]
    args = parser.parse_args(argv)
    chosen = [t for t in TIERS if args.tier is None or t.name in args.tier]
    status, table = 0, []
    for tier in chosen:
        cmd = command(tier, args.suite, extra)
        print(f"== tier {tier.name} (suite {args.suite}: {tier.why}): {' '.join(cmd[1:])}", flush=True)
        start = time.monotonic()
        code = subprocess.call(cmd, cwd=ROOT)
        wall = time.monotonic() - start
        code = 0 if code == 5 else code  # 5: no test selected (a tier empty in this suite)
        table.append((tier.name, code, wall))
        status = status or code
    print("== tiers: " + "; ".join(f"{n} {'passed' if c == 0 else f'FAILED (exit {c})'} in {w:.0f} s" for n, c, w in table))
    return status


if __name__ == "__main__":
    sys.exit(main())
