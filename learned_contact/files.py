"""Checks every model file passes before it is read: a regular file, of bounded size.

A device (/dev/zero), a FIFO or a directory given as a model would otherwise be read
until memory runs out or block forever; a runaway file would be parsed for minutes.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

from learned_contact.errors import WeightsError


def check_regular_file(path: Path, limit: int, what: str = "model file") -> None:
    """WeightsError unless `path` is a regular file of at most `limit` bytes (a device,
    a FIFO or a directory is refused before it is opened for reading)."""
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise WeightsError(f"{what} {path} not found") from None
    except OSError as exc:
        raise WeightsError(f"cannot read {what} {path}: {exc.strerror}") from None
    if not stat.S_ISREG(st.st_mode):
        raise WeightsError(f"{what} {path} is not a regular file; expected a file written by a model exporter")
    if st.st_size > limit:
        raise WeightsError(f"{what} {path} is {st.st_size / 2**20:.1f} MiB; expected at most {limit / 2**20:.0f} MiB")
