"""Nothing dropped: every test the suite collects runs in exactly one tier of CI's suite 1, every test
whose answer can differ between Drake releases (not marked `once`) in the same tier of suite 2, and
README's test command and .ci/run both run tests/tiers.py (so that a tier, once declared, runs)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from _pytest.mark.expression import Expression

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests"))
import tiers  # noqa: E402  (tests/ is not a package: tests/tiers.py is the runner README names)


@pytest.fixture(scope="module")
def collected(tmp_path_factory) -> dict[str, set[str]]:
    """{node id: marker names} of every test a plain `pytest` run collects (pyproject's addopts)."""
    out = tmp_path_factory.mktemp("tiers") / "markers.json"
    env = {**os.environ, "TESTBED_TIER_MARKERS": str(out), "PYTHONPATH": str(ROOT / "tests")}
    proc = subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q", "-p", "no:xdist", "-p", "tier_markers", "-m", ""],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    return {k: set(v) for k, v in json.loads(out.read_text()).items()}


def selected(expression: str, markers: set[str]) -> bool:
    return Expression.compile(expression).evaluate(lambda name, **_: name in markers)


def tiers_of(markers: set[str], suite: int) -> list[str]:
    return [t.name for t in tiers.TIERS if selected(tiers.marks_for(t, suite), markers)]


def test_every_collected_test_runs_in_exactly_one_tier(collected):
    assert len(collected) > 1000  # the whole suite was collected, not one folder
    runs_today = {k: m for k, m in collected.items() if "study" not in m}  # addopts deselects the studies
    nowhere = [k for k, m in runs_today.items() if len(tiers_of(m, 1)) != 1]
    assert not nowhere, f"{len(nowhere)} tests in no tier or in several of suite 1, e.g. {nowhere[:5]}"
    moved = [k for k, m in runs_today.items() if "once" not in m and tiers_of(m, 2) != tiers_of(m, 1)]
    assert not moved, f"{len(moved)} Drake-dependent tests not in suite 2's same tier, e.g. {moved[:5]}"


def test_the_tiers_would_catch_a_test_left_out():
    """The check above fails on a tier table that drops a marker's tests (here: a tier that forgets
    the timing tests, as a runner's `-m` that names a marker nobody runs would)."""
    broken = tuple(t for t in tiers.TIERS if t.name != "timing")
    assert not [t for t in broken if selected(tiers.marks_for(t, 1), {"timing"})]
    assert tiers_of({"timing"}, 1) == ["timing"] and tiers_of({"slow"}, 1) == ["slow"] and tiers_of(set(), 1) == ["fast"]
    assert tiers_of({"once"}, 2) == [] and tiers_of({"once", "slow"}, 1) == ["slow"]


def test_readme_and_ci_run_the_tiers():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    test_line = [line for line in readme.splitlines() if "'.[test]'" in line]
    assert test_line and test_line[0].rstrip().endswith("tests/tiers.py"), test_line
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    assert ".venv/bin/python tests/tiers.py" in ci and ".venv312/bin/python tests/tiers.py --suite 2" in ci


def test_parallel_tiers_keep_a_file_on_one_worker(monkeypatch):
    monkeypatch.setenv("TESTBED_TEST_WORKERS", "2")
    fast, slow, timing = tiers.TIERS
    assert tiers.command(fast, 1, [])[-4:] == ["-n", "2", "--dist", "loadfile"]
    assert "-n" not in tiers.command(timing, 2, []) and "no:xdist" in tiers.command(timing, 2, [])
    assert tiers.command(slow, 2, [])[4] == "(slow and not timing and not study) and not once"
