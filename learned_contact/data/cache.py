"""On-disk cache of generated arrays (never in git).

Location: $TESTBED_CACHE/learned_contact if set, else ~/.cache/testbed/learned_contact.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numpy as np


def cache_dir() -> Path:
    root = os.environ.get("TESTBED_CACHE")
    base = Path(root) if root else Path.home() / ".cache" / "testbed"
    return base / "learned_contact"


def key(*parts) -> str:
    """A file-name-safe key from the repr of `parts`."""
    text = repr(parts)
    return f"{parts[0]}-{hashlib.sha256(text.encode()).hexdigest()[:16]}"


def load(name: str):
    path = cache_dir() / f"{name}.npy"
    return np.load(path) if path.is_file() else None


def save(name: str, array: np.ndarray) -> Path:
    path = cache_dir() / f"{name}.npy"
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(f".tmp{os.getpid()}.npy")
    np.save(tmp, array)
    os.replace(tmp, path)
    return path
