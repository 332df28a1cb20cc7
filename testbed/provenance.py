"""Where a measurement comes from: the date, the commit of the code that made it (when it
runs from a git checkout) and the machine. Reports and the README's results quote it.

`provenance()` -> {"date": "2026-12-02", "commit": "1b5ce52" (+ "-dirty" with uncommitted
changes; "unknown" outside a checkout), "machine": "Linux-... x86_64, 2 CPUs", "python": "3.11.7",
"drake": "1.51.1"}.
"""

from __future__ import annotations

import datetime
import os
import platform
import subprocess
from importlib import metadata
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]  # the checkout, when the package runs from one


def _git(*args: str) -> str | None:
    try:
        done = subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True, timeout=10,
                              stdin=subprocess.DEVNULL)
    except (OSError, subprocess.SubprocessError):
        return None
    return done.stdout.strip() if done.returncode == 0 else None


def commit() -> str:
    """The short commit of the code, '-dirty' when the checkout has uncommitted changes to
    tracked files, 'unknown' when the package does not run from a git checkout."""
    if not (ROOT / ".git").exists():
        return "unknown"
    head = _git("rev-parse", "--short", "HEAD")
    if head is None:
        return "unknown"
    dirty = _git("status", "--porcelain", "--untracked-files=no")
    return head + ("-dirty" if dirty else "")


def provenance() -> dict:
    """{"date", "commit", "machine", "python", "drake"} of a measurement made now."""
    try:
        drake = metadata.version("drake")
    except metadata.PackageNotFoundError:
        drake = "not installed"
    return {"date": datetime.date.today().isoformat(), "commit": commit(),
            "machine": f"{platform.platform()}, {os.cpu_count()} CPUs", "python": platform.python_version(),
            "drake": drake}


def line(p: dict) -> str:
    """'measured 2026-12-02 at commit 1b5ce52 on Linux-..., 2 CPUs (Python 3.11.7, Drake 1.51.1)'."""
    return (f"measured {p['date']} at commit {p['commit']} on {p['machine']} (Python {p['python']}, "
            f"Drake {p['drake']})")
