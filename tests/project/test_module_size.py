"""No Python module of the package code (testbed/, learned_contact/) and no C or C++ file of the
native core (native/) is above MAX_LINES lines: a module that grows past it holds several
concepts, and is split by concept into modules a newcomer can find by name
(testbed/scenario/, learned_contact/predictors/limits_*.py, learned_contact/export/onnx_*.py,
native/src/step_*.c and native/python/*_methods.c show how). A native file that is one concept
above the limit is named in ONE_CONCEPT with why, and its line count is its ceiling."""

from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("testbed", "learned_contact")
NATIVE = "native"
NATIVE_SUFFIXES = {".c", ".h", ".cpp"}
MAX_LINES = 400  # lines of the file, as `wc -l` counts them (comments, docstrings and blank lines included)


def line_count(path: Path) -> int:
    """The file's lines (a last line without a newline counts too)."""
    return len(path.read_text(encoding="utf-8").splitlines())


def modules() -> list[Path]:
    """Every .py file under the packages (compiled caches left out)."""
    return sorted(p for package in PACKAGES for p in (ROOT / package).rglob("*.py") if "__pycache__" not in p.parts)


# native file -> (its ceiling [lines], why it stays one file)
ONE_CONCEPT = {
    "native/src/quadrature.c": (
        500, "one integral: the exact centre of pressure of a face-on-face contact (Drake's linear pressure over "
             "16 fan-triangle polygons and 32 edge slivers); its clipping, strips and sums share one scratch layout "
             "and a dozen inline helpers, which a split would have to export"),
}


def native_files() -> list[Path]:
    """Every C and C++ source and header of the native core (a build folder left out)."""
    return sorted(p for p in (ROOT / NATIVE).rglob("*") if p.suffix in NATIVE_SUFFIXES and "build" not in p.parts)


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


def test_the_listing_finds_the_native_core():
    names = {p.relative_to(ROOT).as_posix() for p in native_files()}
    assert {"native/src/step.c", "native/python/module.c", "native/include/container_contact.h",
            "native/examples/crane_pair.cpp"} <= names and set(ONE_CONCEPT) <= names


def test_no_native_file_is_above_the_limit_or_its_ceiling():
    too_long = []
    for p in native_files():
        name, n = p.relative_to(ROOT).as_posix(), line_count(p)
        ceiling = ONE_CONCEPT.get(name, (MAX_LINES, ""))[0]
        if n > ceiling:
            too_long.append(f"{name}: {n} lines (limit {ceiling})")
    assert not too_long, "native files above their limit (split each by concept):\n" + "\n".join(too_long)


def test_a_one_concept_file_is_above_the_limit_and_says_why():
    for name, (ceiling, why) in ONE_CONCEPT.items():
        assert line_count(ROOT / name) > MAX_LINES, f"{name} fits the limit now: drop it from ONE_CONCEPT"
        assert ceiling > MAX_LINES and len(why) > 40, name
