"""No Python module of the package code (testbed/, learned_contact/) is above MAX_LINES lines:
a module that grows past it holds several concepts, and is split by concept into modules
a newcomer can find by name (testbed/scenario/, learned_contact/predictors/limits_*.py and
learned_contact/export/onnx_*.py show how)."""

from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("testbed", "learned_contact")
MAX_LINES = 400  # lines of the file, as `wc -l` counts them (comments, docstrings and blank lines included)


def line_count(path: Path) -> int:
    """The file's lines (a last line without a newline counts too)."""
    return len(path.read_text(encoding="utf-8").splitlines())


def modules() -> list[Path]:
    """Every .py file under the packages (compiled caches left out)."""
    return sorted(p for package in PACKAGES for p in (ROOT / package).rglob("*.py") if "__pycache__" not in p.parts)


def test_the_listing_finds_the_packages_modules():
    found = modules()
    names = {p.relative_to(ROOT).as_posix() for p in found}
    assert len(found) > 100 and "testbed/cli.py" in names and "learned_contact/interface.py" in names


def test_line_count_counts_every_line(tmp_path):
    path = tmp_path / "m.py"
    path.write_text("x = 1\n" * (MAX_LINES + 1), encoding="utf-8")
    assert line_count(path) == MAX_LINES + 1
    path.write_text("\n" * 3 + "y = 2", encoding="utf-8")  # blank lines count; so does an unterminated last line
    assert line_count(path) == 4


def test_no_module_is_above_the_limit():
    too_long = [f"{p.relative_to(ROOT).as_posix()}: {n} lines" for p in modules() if (n := line_count(p)) > MAX_LINES]
    assert not too_long, f"modules above {MAX_LINES} lines (split each by concept):\n" + "\n".join(too_long)
