"""The repository stands on its own: no file refers to a folder beside the
checkout, the design record and the toss data are inside it, and every command that reads
tosses defaults to the shipped copy."""

import argparse
import re
from pathlib import Path

from testbed.calibration.data import SHIPPED_TOSSES, load_tosses

ROOT = Path(__file__).resolve().parents[2]
# the folder beside the repository that a user's clone does not have (spelt in parts so that
# this file does not match its own pattern)
_BESIDE = "sha" + "red"
_OUTSIDE = re.compile(rf"\.\./{_BESIDE}|{_BESIDE}/data|{_BESIDE}/DESIGN|/work/")
_TEXT = {".py", ".md", ".toml", ".yaml", ".yml", ".json", ".txt", ".cfg", ".sdf", ".html"}


def test_no_file_refers_outside_the_repository():
    offenders = []
    for path in ROOT.rglob("*"):
        parts = path.relative_to(ROOT).parts
        if path.suffix not in _TEXT or not path.is_file() or any(p.startswith(".") or p in ("reports", "__pycache__") for p in parts):
            continue
        for n, line in enumerate(path.read_text(errors="replace").splitlines(), 1):
            if _OUTSIDE.search(line) and path.name != "test_self_contained.py":
                offenders.append(f"{path.relative_to(ROOT)}:{n}: {line.strip()[:100]}")
    assert not offenders, "\n".join(offenders)


def test_design_record_and_data_are_inside_and_linked():
    assert (ROOT / "testbed" / "DESIGN.md").is_file()
    assert "(testbed/DESIGN.md)" in (ROOT / "README.md").read_text()
    readme = (SHIPPED_TOSSES.parent / "README.md").read_text()
    assert "BSD 3-Clause" in readme and "Dynamic Autonomy and Intelligent Robotics Lab" in readme and "even-numbered" in readme
    tosses = load_tosses(SHIPPED_TOSSES)
    assert len(tosses.tosses) == 275 and all(t.toss_id % 2 == 0 for t in tosses.tosses)  # the even half, as stated
    assert "calibration/cube_tosses/*" in (ROOT / "pyproject.toml").read_text()  # installed with the package


def test_every_toss_command_defaults_to_the_shipped_copy():
    from testbed.commands import calibrate, study

    parser = argparse.ArgumentParser()
    calibrate.add_arguments(parser)
    assert parser.parse_args(["fit", "--out", "o"]).data == str(SHIPPED_TOSSES)
    assert parser.parse_args(["evaluate", "--params", "p.yaml", "--out", "o"]).data == str(SHIPPED_TOSSES)
    parser = argparse.ArgumentParser()
    study.add_arguments(parser)
    assert parser.parse_args(["defaults"]).toss_data == str(SHIPPED_TOSSES)
