"""The runnable examples (examples/) run as a user runs them, and what they print is right:
each check reads the figures an example prints and holds them to physics or to the contract.
Also: the version in pyproject.toml, testbed.__version__ and CHANGELOG.md's newest entry agree."""

import re
import subprocess
import sys
from pathlib import Path

import pytest

import testbed

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"


def _run(name: str) -> str:
    proc = subprocess.run([sys.executable, str(EXAMPLES / name)], capture_output=True, text=True, timeout=300,
                          cwd=ROOT, stdin=subprocess.DEVNULL)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return proc.stdout


def _number(pattern: str, text: str) -> float:
    found = re.search(pattern, text)
    assert found, (pattern, text)
    return float(found.group(1))


def test_every_example_is_tested():
    tested = {"run_a_scene.py", "judge_your_model.py", "write_an_effect.py", "write_an_engine.py", "my_model.py"}
    assert {p.name for p in EXAMPLES.glob("*.py")} == tested


def test_run_a_scene():
    out = _run("run_a_scene.py")
    # a resting stack settles by its contact compliance only: well under a millimetre (20 t on 1e9 Pa)
    assert 0 < _number(r"settles ([\d.]+) mm", out) < 1.0
    assert _number(r"my_yard: (\d+) containers", out) == 12  # 2 rows x 3 bays x 2 tiers
    # a yard at rest stays put: 5 mm bounds the point-contact settling of two tiers in 0.1 s
    assert _number(r"largest displacement in [\d.]+ s is ([\d.]+) mm", out) < 5.0


def test_judge_your_model():
    out = _run("judge_your_model.py")
    point_z = _number(r"contact point \[[-\d. ]+? ([\d.]+)\] m in A", out)
    assert point_z == pytest.approx(2.591 / 2, abs=1e-3)  # on A's top face, where B rests
    assert re.search(r"windy_stack in the loop: (PASS|FAIL), final position [\d.e+-]+ mm", out), out


def test_write_an_effect():
    out = _run("write_an_effect.py")
    # 200 kN for 0.2 s on 20 t against Coulomb friction (mu 0.4: 78.5 kN): a = 6.08 m/s^2 to 1.22 m/s
    # (0.122 m), then it slides to rest at mu g = 3.92 m/s^2 (0.189 m): 0.31 m in all; 15 % for the
    # contact's compliance and the 1 ms steps
    assert _number(r"the box moved ([\d.]+) mm", out) == pytest.approx(311.0, rel=0.15)
    assert "effects.gust.force" in out.splitlines()[-1]


def test_write_an_engine():
    out = _run("write_an_engine.py")
    mine = _number(r"falling boxes z = ([\d.]+) m", out)
    drake = _number(r"Drake z = ([\d.]+) m", out)
    # both rest with the box's centre at its half height (1.2955 m) above the quay, within their compliance
    assert mine == pytest.approx(1.2955, abs=2e-3) and drake == pytest.approx(1.2955, abs=2e-3)


def test_the_version_is_one_and_changelogged():
    pyproject = re.search(r'^version = "([^"]+)"', (ROOT / "pyproject.toml").read_text(), re.M).group(1)
    newest = re.search(r"^## (\S+)", (ROOT / "CHANGELOG.md").read_text(), re.M).group(1)
    assert pyproject == testbed.__version__ == newest
