"""The type check: mypy ([tool.mypy] in pyproject.toml) finds nothing in the foundation and the
public interfaces (errors, geometry, file readers, plug-in bases, the predictor contract and
its loaders)."""

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def test_mypy_finds_nothing():
    beside = Path(sys.executable).with_name("mypy")
    mypy = str(beside) if beside.exists() else shutil.which("mypy")
    if mypy is None:
        pytest.skip("mypy is in the test extra: pip install -e '.[test]' (or pip install mypy==2.4.1)")
    done = subprocess.run([mypy, "--no-incremental"], cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout[-4000:] + done.stderr[-2000:]
