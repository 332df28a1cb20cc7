"""Source, tests and docs name no tracker issue ("issue 37"): a reader of the repository has
no tracker, so a reason must be stated where it applies. CHANGELOG.md, the project's history,
may name them."""

import re
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PATTERN = re.compile(r"(?<!MuJoCo )\b[Ii]ssues? ?#?\d+\b")  # another project's public tracker may be cited
EXEMPT = {"CHANGELOG.md", "test_no_issue_numbers.py"}


def tracked_text_files() -> list[Path]:
    out = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True).stdout.split()
    keep = (".py", ".md", ".c", ".h", ".cpp", ".yaml", ".toml", ".txt", ".cfg", ".in")
    return [ROOT / f for f in out if f.endswith(keep) and Path(f).name not in EXEMPT]


def test_no_file_names_a_tracker_issue():
    files = tracked_text_files()
    assert len(files) > 100  # the listing worked (git is there and the repository is this one)
    found = []
    for path in files:
        for number, line in enumerate(path.read_text(errors="replace").splitlines(), 1):
            if PATTERN.search(line):
                found.append(f"{path.relative_to(ROOT)}:{number}: {line.strip()[:100]}")
    assert not found, "tracker issue numbers in the repository:\n" + "\n".join(found)


def test_the_pattern_finds_what_it_guards():
    assert PATTERN.search("(issue 37)") and PATTERN.search("Issue 30's target") and PATTERN.search("issue #12")
    assert not PATTERN.search("an issue with the solver") and not PATTERN.search("tissue 3")
    assert not PATTERN.search("MuJoCo issue 3767")
