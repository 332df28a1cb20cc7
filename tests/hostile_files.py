"""Hostile input files: each is made in a directory and returned as a path.

Every class must give one line naming the file and the problem, exit status 2, in under 2 s and
under 1 GiB, with nothing written. Used by tests/foundation/test_hostile_files.py and by hand:
`python tests/hostile_files.py DIR` writes them all and prints their paths.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from test_bad_input import GOOD


def alias_bomb(directory: Path, fanout: int = 10, levels: int = 9) -> Path:
    """An anchor referenced `fanout` times per level, `levels` deep (fanout**levels nodes once
    expanded), inside a field the schema knows (the description)."""
    anchors = ["&l0 [bomb]"]
    for level in range(1, levels + 1):
        anchors.append(f"&l{level} [" + ", ".join([f"*l{level - 1}"] * fanout) + "]")
    body = "\n".join(f"  - {a}" for a in anchors)
    return _write(directory / "alias_bomb.yaml", GOOD.replace("duration: 0.01", "duration: 0.01\ndescription:\n" + body))


def deep_flow(directory: Path, depth: int = 50_000) -> Path:
    """Tens of thousands of nested flow brackets as a field's value."""
    return _write(directory / "deep_flow.yaml", GOOD + "description: " + "[" * depth + "]" * depth + "\n")


def duplicate_key(directory: Path) -> Path:
    """The same field twice in one mapping (the second used to win silently)."""
    return _write(directory / "duplicate_key.yaml", GOOD.replace("  mass: 20000", "  mass: 20000\n  mass: 25000"))


def oversized(directory: Path, megabytes: int = 40) -> Path:
    """A valid scene padded with a long comment block to `megabytes` MB."""
    pad = ("# " + "x" * 97 + "\n") * (megabytes * 10_000)
    return _write(directory / "oversized.yaml", GOOD + pad)


def fifo(directory: Path) -> Path:
    """A named pipe with no writer (opening it for reading would block forever)."""
    path = directory / "pipe.yaml"
    os.mkfifo(path)
    return path


def a_directory(directory: Path) -> Path:
    path = directory / "folder.yaml"
    path.mkdir()
    return path


DEV_ZERO = Path("/dev/zero")  # a device: reading it never ends

MAKERS = {"alias_bomb": alias_bomb, "deep_flow": deep_flow, "duplicate_key": duplicate_key, "oversized": oversized,
          "fifo": fifo, "directory": a_directory, "dev_zero": lambda directory: DEV_ZERO}


def _write(path: Path, text: str) -> Path:
    path.write_text(text, encoding="utf-8")
    return path


if __name__ == "__main__":
    out = Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    for name, make in MAKERS.items():
        print(name, make(out))
