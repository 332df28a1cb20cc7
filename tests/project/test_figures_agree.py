"""README's yard table says each cost twice: milliseconds per step and, in brackets, the real-time
factor. At a step of h ms the factor is h / (ms per step), so the two must agree to the rounding
they are printed with; a cell may give a range over runs ("0.61-0.69 (1.4-1.6x)"), whose ends
then agree crosswise (the fastest run's ms with the largest factor). Cells without a factor are
skipped."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

pytestmark = pytest.mark.once  # reads a document, the same under every Drake release

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"
_NUM = r"\d+(?:\.\d+)?"
_CELL = re.compile(rf"^\s*({_NUM})(?:-({_NUM}))?\s*\(\s*({_NUM})(?:-({_NUM}))?x\s*\)\s*$")
_STEP = re.compile(rf"\b({_NUM}) ms step\b")


def _half_unit(text: str) -> float:
    """Half of the last printed digit's unit: the rounding a printed figure carries."""
    decimals = len(text.split(".", 1)[1]) if "." in text else 0
    return 0.5 * 10.0 ** -decimals


def _interval(text: str) -> tuple[float, float]:
    return float(text) - _half_unit(text), float(text) + _half_unit(text)


def yard_table(text: str) -> tuple[float, list[tuple[str, str, str, str, str]]]:
    """(the step [ms] the paragraph above the table states, [(row label, column, the cell, ms
    'lo-hi', factor 'lo-hi')] of every cell with a factor) of the first table whose header starts
    '| containers |'."""
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("| containers |"))
    above = "\n".join(lines[max(0, start - 8):start])
    steps = _STEP.findall(above)
    assert len(steps) == 1, f"the paragraph above the yard table names one step, found {steps}"
    header = [c.strip() for c in lines[start].strip().strip("|").split("|")]
    cells = []
    for line in lines[start + 2:]:
        if not line.startswith("|"):
            break
        row = [c.strip() for c in line.strip().strip("|").split("|")]
        for column, cell in zip(header[1:], row[1:]):
            m = _CELL.match(cell)
            if m:
                lo, hi, f_lo, f_hi = m.groups()
                cells.append((row[0], column, cell, f"{lo}-{hi or lo}", f"{f_lo}-{f_hi or f_lo}"))
    return float(steps[0]), cells


def _agree(step_ms: float, ms_text: str, factor_text: str) -> bool:
    """True when factor = step / ms holds for some values each printed figure rounds from."""
    (ms_lo, ms_hi), (f_lo, f_hi) = ms_text.split("-"), factor_text.split("-")
    for ms, factor in ((ms_lo, f_hi), (ms_hi, f_lo)):  # fastest with the largest factor
        m0, m1 = _interval(ms)
        f0, f1 = _interval(factor)
        if not (step_ms / m1 <= f1 and step_ms / m0 >= f0):
            return False
    return True


def test_the_checker_catches_a_disagreement():
    assert _agree(1.0, "0.19-0.19", "5.39-5.39") and _agree(1.0, "1.82-1.82", "0.55-0.55")
    assert not _agree(1.0, "0.58-0.58", "1.06-1.06")  # 1 / 0.58 is 1.72x
    assert not _agree(1.0, "1.27-1.27", "0.55-0.55")
    assert _agree(1.0, "0.61-0.69", "1.4-1.6") and not _agree(1.0, "0.61-0.69", "1.6-1.4")


def test_readme_yard_table_ms_and_real_time_factor_agree():
    step_ms, cells = yard_table(README.read_text(encoding="utf-8"))
    assert step_ms > 0
    assert len(cells) >= 4, f"the yard table's ms (x real time) cells were not found: {cells}"
    wrong = [f"{row} at {col}: '{cell}', but {ms.split('-')[0]} ms per step is "
             f"{step_ms / float(ms.split('-')[0]):.3g}x at the {step_ms:g} ms step"
             for row, col, cell, ms, factor in cells if not _agree(step_ms, ms, factor)]
    assert not wrong, "README's yard table contradicts itself:\n" + "\n".join(wrong)
