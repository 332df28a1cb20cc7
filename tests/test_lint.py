"""Lint: `ruff check` ([tool.ruff] in pyproject.toml) finds nothing in testbed/,
learned_contact/ and tests/."""

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def _ruff() -> str | None:
    beside = Path(sys.executable).with_name("ruff")  # the venv's, as lint-imports in test_architecture.py
    return str(beside) if beside.exists() else shutil.which("ruff")


def test_ruff_finds_nothing():
    ruff = _ruff()
    if ruff is None:
        pytest.skip("ruff is in the test extra: pip install -e '.[test]' (or pip install ruff==0.17.6)")
    done = subprocess.run([ruff, "check", "--no-cache", "testbed", "learned_contact", "tests"], cwd=ROOT,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout[-4000:] + done.stderr[-2000:]
