"""Lint: `ruff check` ([tool.ruff] in pyproject.toml) finds nothing in testbed/, examples/,
learned_contact/ and tests/; the project's own modules are imported at the module top
(function-local imports only where ALLOWED says why)."""

import ast
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.once  # ruff reads the source: the same on every Drake release

ROOT = Path(__file__).resolve().parents[2]


def _ruff() -> str | None:
    beside = Path(sys.executable).with_name("ruff")  # the venv's, as lint-imports in test_architecture.py
    return str(beside) if beside.exists() else shutil.which("ruff")


def test_ruff_finds_nothing():
    ruff = _ruff()
    if ruff is None:
        pytest.skip("ruff is in the test extra: pip install -e '.[test]' (or pip install ruff==0.17.6)")
    done = subprocess.run([ruff, "check", "--no-cache", "testbed", "learned_contact", "tests", "examples"], cwd=ROOT,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout[-4000:] + done.stderr[-2000:]


# ----------------------------------------------------------------------------- imports at the top
# A function-local import of the project's own modules hides a dependency from readers and
# tools. Allowed: the `run` functions of testbed/commands/ (the CLI imports every command
# module to build its parser, so its start-up stays light) and the functions of ALLOWED, each
# with its reason.
# Lazy imports of optional heavy packages (torch, mujoco, fcl, ray, matplotlib, onnxruntime,
# playwright) are not project modules and stay where they are.
PROJECT = ("testbed", "learned_contact")
_CLI = "called only by the command's `run`: the CLI's start-up stays light"
_DRAKE = "keeps Drake (pydrake) out of a module that imports without it"
_ENGINE = "an engine's registration stays light: the CLI's parser lists the engines; its simulator loads when it runs"
_STUDY = "a study's registration stays light: the CLI's parser lists the studies and their options; its code loads when it runs"
ALLOWED = {  # (file, function) -> why its imports of project modules stay inside it
    ("testbed/studies/sim/__init__.py", "_code"): _STUDY,
    ("testbed/studies/stability/__init__.py", "_code"): _STUDY,
    ("testbed/studies/defaults/__init__.py", "_code"): _STUDY,
    ("testbed/studies/scale/__init__.py", "_code"): _STUDY,
    ("testbed/studies/truth/__init__.py", "_code"): _STUDY,
    ("testbed/engines/drake/__init__.py", "run"): _ENGINE,
    ("testbed/engines/bullet/__init__.py", "unavailable"): _ENGINE,
    ("testbed/engines/bullet/__init__.py", "version"): _ENGINE,
    ("testbed/engines/bullet/__init__.py", "check"): _ENGINE,
    ("testbed/engines/bullet/__init__.py", "run"): _ENGINE,
    ("testbed/engines/mujoco/__init__.py", "unavailable"): _ENGINE,
    ("testbed/engines/mujoco/__init__.py", "version"): _ENGINE,
    ("testbed/engines/mujoco/__init__.py", "check"): _ENGINE,
    ("testbed/engines/mujoco/__init__.py", "run"): _ENGINE,
    ("testbed/engines/mujoco_learned/__init__.py", "unavailable"): _ENGINE,
    ("testbed/engines/mujoco_learned/__init__.py", "version"): _ENGINE,
    ("testbed/engines/mujoco_learned/__init__.py", "check"): _ENGINE,
    ("testbed/engines/mujoco_learned/__init__.py", "run"): _ENGINE,
    ("testbed/commands/view.py", "view"): _CLI,
    ("testbed/studies/__init__.py", "__getattr__"): "lazy package attribute (PEP 562): the query study on first use",
    ("testbed/effects/learned_dynamics/force_law.py", "fit_pressure_stiffness"):
        _DRAKE + " (the force law is imported by the CLI's compare command; only the fit needs a Drake pair plant)",
    ("learned_contact/data/labels.py", "pair_scene"): _DRAKE + " (learned_contact; labelling alone needs Drake's answer)",
    ("learned_contact/data/labels.py", "label_one"): _DRAKE + " (learned_contact; labelling alone needs Drake's answer)",
}


def _function_local_imports(path: Path):
    """(function name, imported module, line) of each import of a project module inside a function."""
    tree = ast.parse(path.read_text(), str(path))
    for fn in ast.walk(tree):
        if not isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
            continue
        for node in ast.walk(fn):
            if isinstance(node, ast.Import):
                modules = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                modules = [node.module] if node.module not in PROJECT else [f"{node.module}.{a.name}" for a in node.names]
            else:
                continue
            for module in modules:
                if module.split(".")[0] in PROJECT:
                    yield fn.name, module, node.lineno


def _allowed(rel: str, function: str, module: str) -> bool:
    if rel.startswith("testbed/commands/") and function == "run":
        return True
    return (rel, function) in ALLOWED


def test_project_imports_are_at_the_top():
    found, used = [], set()
    for package in PROJECT:
        for path in sorted((ROOT / package).rglob("*.py")):
            rel = path.relative_to(ROOT).as_posix()
            for function, module, line in _function_local_imports(path):
                if (rel, function) in ALLOWED:
                    used.add((rel, function))
                if not _allowed(rel, function, module):
                    found.append(f"{rel}:{line} {function}() imports {module}")
    assert not found, ("function-local imports of project modules (move them to the module top, or add "
                       "(file, function) to ALLOWED with the reason):\n" + "\n".join(found))
    assert not set(ALLOWED) - used, f"ALLOWED entries with no local import left: {sorted(set(ALLOWED) - used)}"
