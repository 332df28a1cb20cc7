"""The user documents: README.md (the front door) and docs/ (the reference by topic).

Every relative link points to a file that exists (anchors ignored), no issue-tracker
number appears (readers of the repository cannot see the tracker), and README.md stays
one screen's worth of front door (under 200 lines).
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DOCS = sorted((ROOT / "docs").glob("*.md"))
README = ROOT / "README.md"
# [text](target) or [text](target "title"); images too. Targets with a scheme are not files.
_LINK = re.compile(r"!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
_ISSUE = re.compile(r"\b[Ii]ssues? #?\d+")
_FENCE = re.compile(r"^```.*?^```", re.S | re.M)


def _links(path: Path) -> list[str]:
    text = _FENCE.sub("", path.read_text(encoding="utf-8"))  # code blocks hold no links
    return [m.group(1) for m in _LINK.finditer(text)]


def _dead_links(path: Path) -> list[str]:
    dead = []
    for target in _links(path):
        if re.match(r"^[a-z][a-z0-9+.-]*:", target) or target.startswith("#"):
            continue  # http:, mailto:, an anchor in the same file
        file_part = target.split("#", 1)[0]
        if not (path.parent / file_part).exists():
            dead.append(f"{path.relative_to(ROOT)}: {target}")
    return dead


def _issue_mentions(path: Path) -> list[str]:
    return [f"{path.relative_to(ROOT)}:{n}: {line.strip()[:100]}"
            for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1) if _ISSUE.search(line)]


def test_docs_exist_and_are_indexed():
    assert DOCS, "docs/*.md missing"
    index = (ROOT / "docs" / "README.md").read_text(encoding="utf-8")
    for path in DOCS:
        if path.name != "README.md":
            assert f"({path.name})" in index, f"docs/README.md does not link {path.name}"


@pytest.mark.parametrize("path", DOCS, ids=lambda p: p.name)
def test_docs_links_point_to_existing_files(path):
    assert not _dead_links(path), "\n".join(_dead_links(path))


@pytest.mark.parametrize("path", DOCS, ids=lambda p: p.name)
def test_docs_name_no_issue_numbers(path):
    assert not _issue_mentions(path), "\n".join(_issue_mentions(path))


def test_readme_links_point_to_existing_files():
    assert not _dead_links(README), "\n".join(_dead_links(README))


def test_readme_names_no_issue_numbers():
    assert not _issue_mentions(README), "\n".join(_issue_mentions(README))


def test_readme_is_a_front_door():
    lines = len(README.read_text(encoding="utf-8").splitlines())
    assert lines < 200, f"README.md has {lines} lines; the reference belongs in docs/"
