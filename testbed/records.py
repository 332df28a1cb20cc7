"""Run records: columnar tables in .npz files, a JSON summary, written atomically.

A run directory holds:
  scenario.yaml   the fully resolved scenario (yaml_dump_typed), to reproduce the run
  steps.npz       one row per logged step (time, poses, velocities, energy)
  contacts.npz    one row per contact per step (testbed/contact/extraction.py columns,
                  plus `step` and `time`), the driving model's answer
  shadow.npz      same columns, the shadow model's answer on the same states
  <effect>.npz    further tables added by effects (e.g. learned comparison)
  summary.json    headline figures

Read a table with `np.load(path)` (arrays keyed by column) or `load_table`; turn it
(or its path) into a pandas DataFrame with `to_frame` (vector columns become `name_0..name_k`).
Body indices: contacts' `a`, `b` index summary.json's `body_names` (the ground first, then
the containers in the scene's order); steps' second axis indexes the free (not welded)
containers in the scene's order, so on a scene without welded boxes steps' index j is
body_names[j + 1].
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np

RECORD_PERIOD = 0.01  # [s] spacing of the recorded (sampled) states of every recorded run and logged scene


def steps_per_record(time_step: float, period: float = RECORD_PERIOD) -> int:
    """Plant steps between records: `period` [s] in whole steps of `time_step` [s] (>= 1)."""
    return max(1, int(round(period / time_step)))


class TableBuilder:
    """Collects per-step column dicts and concatenates them once at the end."""

    def __init__(self):
        self._chunks: list[dict[str, np.ndarray]] = []

    def append(self, step: int, time: float, columns: dict[str, np.ndarray]) -> None:
        n = len(next(iter(columns.values()))) if columns else 0
        if n == 0:
            return
        chunk = dict(columns)
        chunk["step"] = np.full(n, step, dtype=np.int64)
        chunk["time"] = np.full(n, time)
        self._chunks.append(chunk)

    def latest(self) -> tuple[int, float, dict[str, np.ndarray]] | None:
        """(step, time, columns) of the most recent non-empty append, or None."""
        if not self._chunks:
            return None
        chunk = self._chunks[-1]
        return int(chunk["step"][0]), float(chunk["time"][0]), chunk

    def chunks_for_step(self, step: int) -> list[dict[str, np.ndarray]]:
        """The appended column dicts of `step` (searching from the newest)."""
        out = []
        for chunk in reversed(self._chunks):
            s = int(chunk["step"][0])
            if s == step:
                out.append(chunk)
            elif s < step:
                break
        return out

    def chunks_after_step(self, step: int) -> list[dict[str, np.ndarray]]:
        """The appended column dicts with a step greater than `step`, oldest first."""
        out = []
        for chunk in reversed(self._chunks):
            if int(chunk["step"][0]) <= step:
                break
            out.append(chunk)
        return out[::-1]

    def build(self, empty: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        if not self._chunks:
            out = dict(empty)
            out["step"] = np.zeros(0, dtype=np.int64)
            out["time"] = np.zeros(0)
            return out
        return {k: np.concatenate([c[k] for c in self._chunks]) for k in self._chunks[0]}


def save_table(path: Path, table: dict[str, np.ndarray]) -> None:
    np.savez_compressed(path, **table)


def load_table(path: str | Path) -> dict[str, np.ndarray]:
    with np.load(path, allow_pickle=False) as data:
        return {k: data[k] for k in data.files}


def to_frame(table: dict[str, np.ndarray] | str | Path):
    """A pandas DataFrame of a table (a dict of columns, or the path of a table's .npz file,
    e.g. a run's contacts.npz) with vector columns split into name_0, name_1, ... in C order
    (steps.npz's p_WB (n, m, 3): p_WB_0..2 = container 0's x, y, z, p_WB_3..5 container 1's).
    Needs pandas (`pip install -e '.[frames]'`)."""
    import pandas as pd  # optional; only this helper needs it

    if isinstance(table, (str, os.PathLike)):
        table = load_table(table)
    flat = {}
    for key, value in table.items():
        if value.ndim == 1:
            flat[key] = value
        else:
            for i, column in enumerate(value.reshape(len(value), -1).T):
                flat[f"{key}_{i}"] = column
    return pd.DataFrame(flat)


def json_default(value):
    """json.dumps default= for numpy scalars and arrays."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


def write_json(path: Path, data: dict) -> None:
    write_atomic(path, json.dumps(data, indent=2, default=json_default, allow_nan=True) + "\n")


def write_atomic(path: str | Path, data: str | bytes) -> Path:
    """Writes one file atomically: a temporary file beside `path`, then a rename.

    The one atomic file write of the project (a directory of files: atomic_directory).
    A reader sees the old file or the whole new one, never a part; on any error the
    temporary file is removed. Parent directories are made. Returns the path.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.partial-{os.getpid()}")
    try:
        if isinstance(data, bytes):
            tmp.write_bytes(data)
        else:
            tmp.write_text(data, encoding="utf-8")
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


@contextlib.contextmanager
def atomic_directory(final: str | Path):
    """Yields a temporary directory beside `final`; renames it to `final` only on success.

    An existing `final` is replaced only after the new one is complete; on any error
    the temporary directory is removed and `final` is left as it was.
    """
    final = Path(final).resolve()
    final.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{final.name}.partial-", dir=final.parent))
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o777 & ~umask)  # mkdtemp makes 0700; a run directory is an ordinary folder
    try:
        yield tmp
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    if final.exists():
        old = Path(tempfile.mkdtemp(prefix=f".{final.name}.old-", dir=final.parent))
        os.replace(final, old / "x")
        os.replace(tmp, final)
        shutil.rmtree(old, ignore_errors=True)
    else:
        os.replace(tmp, final)
