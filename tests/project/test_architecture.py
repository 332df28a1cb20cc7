"""The import contracts of pyproject.toml ([tool.importlinter]) hold: the layers
(commands over validation over studies, over the scene pipeline, over the effects,
over viz and learned_contact, over the foundation), learned_contact never importing
testbed's viewer, validation, commands or CLI, and no import cycles within a package."""

import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.once  # the import contracts read the source

ROOT = Path(__file__).resolve().parents[2]


def test_import_contracts_hold():
    lint = Path(sys.executable).with_name("lint-imports")
    if not lint.exists():
        pytest.skip("import-linter is in the test extra: pip install -e '.[test]'")
    done = subprocess.run([str(lint), "--no-cache"], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout[-4000:] + done.stderr[-2000:]
