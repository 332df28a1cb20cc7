"""Loading recorded cube tosses (the DAIR Lab cube data set's .npz format) with clear errors.

File format (see testbed/calibration/cube_tosses/README.md; the shipped file is SHIPPED_TOSSES):
  states  (N, 13) float: per frame q_WB (w, x, y, z), p_WB [m] in W, w_WB_B [rad/s] (angular
          velocity expressed in the BODY frame B), v_WB [m/s] in W
  offsets (n + 1,) int: toss k is states[offsets[k]:offsets[k + 1]]
  toss_id (n,) int: the toss's number in the original set
  dt      () float: time between frames [s]

The object: a 0.1048 m cube of 0.37 kg, 0.00081 kg m^2 about each axis (the source URDF).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from testbed.errors import TestbedError
from testbed.safe_files import load_npz

# The even-numbered half of the DAIR Lab cube tosses, shipped in the package (BSD-3-Clause,
# DAIRLab; source, subset and licence in cube_tosses/README.md): the default of every command
# that needs toss data (`testbed calibrate fit|evaluate`, `testbed study defaults`).
SHIPPED_TOSSES = Path(__file__).resolve().parent / "cube_tosses" / "even.npz"
CUBE_WIDTH = 0.1048  # [m] edge length; the metric divides by it
CUBE_MASS = 0.37  # [kg]
CUBE_INERTIA = 0.00081  # [kg m^2] about each principal axis through the centre
TABLE_HEIGHT = -0.0011  # [m] the table top's z, from resting frames (README of the data)
MIN_FRAMES = 2
# Size limits, checked before numpy reads anything: the shipped half of the data set is a 2.7 MB
# file of 3.0 MB of arrays (275 tosses); the limits leave room for about 40x the whole set.
MAX_TOSS_FILE_BYTES = 128 * 2**20  # [bytes] the .npz file
MAX_TOSS_ARRAY_BYTES = 256 * 2**20  # [bytes] its arrays once unpacked (a zip bomb is refused from the zip directory)


class CalibrationDataError(TestbedError, ValueError):
    """A toss file that cannot be used: names the file, the field and what was expected."""

    def __init__(self, path: object, field: str, problem: str):
        self.path, self.field, self.problem = str(path), field, problem
        super().__init__(f"{self.path}: {field}: {problem}" if field else f"{self.path}: {problem}")


@dataclasses.dataclass(frozen=True)
class Toss:
    """One recorded toss; n frames at times t."""

    toss_id: int
    t: np.ndarray  # (n,) [s] from the first frame
    q_WB: np.ndarray  # (n, 4) unit quaternion w, x, y, z of the cube in W
    p_WB: np.ndarray  # (n, 3) cube centre in W [m]
    w_WB_B: np.ndarray  # (n, 3) angular velocity of B in W, expressed in B [rad/s]
    v_WB: np.ndarray  # (n, 3) velocity of the centre in W [m/s]

    def __len__(self) -> int:
        return len(self.t)


@dataclasses.dataclass(frozen=True)
class TossSet:
    path: str
    dt: float  # [s] between frames
    tosses: list[Toss]

    def subset(self, indices) -> "TossSet":
        return TossSet(self.path, self.dt, [self.tosses[i] for i in indices])


def load_tosses(path: str | Path) -> TossSet:
    """Reads a toss .npz file; raises CalibrationDataError naming file, field and expectation.
    The file must be a regular file of at most MAX_TOSS_FILE_BYTES whose arrays unpack to at most
    MAX_TOSS_ARRAY_BYTES (testbed/safe_files.py; checked from the zip directory before reading)."""
    path = Path(path)
    arrays = load_npz(path, MAX_TOSS_FILE_BYTES, MAX_TOSS_ARRAY_BYTES,
                      "toss file (.npz with states, offsets, toss_id, dt)", CalibrationDataError)
    for key in ("states", "offsets", "toss_id", "dt"):
        if key not in arrays:
            raise CalibrationDataError(path, key, f"missing array; the file has {sorted(arrays)}; expected states, offsets, toss_id, dt")
    states, offsets, toss_id, dt = arrays["states"], arrays["offsets"], arrays["toss_id"], arrays["dt"]
    if states.ndim != 2 or states.shape[1] != 13 or not np.issubdtype(states.dtype, np.floating):
        raise CalibrationDataError(path, "states", f"expected a (N, 13) float array, got shape {states.shape} of {states.dtype}")
    if not np.all(np.isfinite(states)):
        raise CalibrationDataError(path, "states", f"expected finite values, found {int(np.sum(~np.isfinite(states)))} NaN/inf")
    if dt.shape != () or not np.issubdtype(dt.dtype, np.number) or not float(dt) > 0:
        raise CalibrationDataError(path, "dt", f"expected a positive scalar [s], got {dt!r}")
    if offsets.ndim != 1 or not np.issubdtype(offsets.dtype, np.integer) or len(offsets) < 2:
        raise CalibrationDataError(path, "offsets", f"expected a 1-D integer array of n + 1 >= 2 entries, got shape {offsets.shape} of {offsets.dtype}")
    lengths = np.diff(offsets)
    if offsets[0] != 0 or offsets[-1] != len(states) or np.any(lengths < MIN_FRAMES):
        raise CalibrationDataError(
            path, "offsets",
            f"expected increasing offsets from 0 to len(states) = {len(states)} with at least {MIN_FRAMES} frames "
            f"per toss; got first {int(offsets[0])}, last {int(offsets[-1])}, shortest toss {int(lengths.min())} frames")
    if toss_id.shape != (len(offsets) - 1,) or not np.issubdtype(toss_id.dtype, np.integer):
        raise CalibrationDataError(path, "toss_id", f"expected ({len(offsets) - 1},) integers (one per toss), got shape {toss_id.shape} of {toss_id.dtype}")
    norms = np.linalg.norm(states[:, :4], axis=1)
    if np.any(np.abs(norms - 1) > 1e-3):  # 1e-3: float32-rounded mocap quaternions pass, garbage does not
        raise CalibrationDataError(path, "states[:, 0:4]", f"expected unit quaternions (w, x, y, z); norms range {norms.min():.4f}..{norms.max():.4f}")
    tosses = []
    for k in range(len(lengths)):
        s = states[offsets[k]:offsets[k + 1]]
        q = s[:, :4] / np.linalg.norm(s[:, :4], axis=1, keepdims=True)
        tosses.append(Toss(int(toss_id[k]), np.arange(len(s)) * float(dt), q, s[:, 4:7].copy(), s[:, 7:10].copy(), s[:, 10:13].copy()))
    return TossSet(str(path), float(dt), tosses)


def save_tosses(path: str | Path, tosses: list[Toss], dt: float) -> Path:
    """Writes tosses in the format `load_tosses` reads (e.g. a subset, or simulated tosses)."""
    path = Path(path)
    states = np.concatenate([np.hstack([t.q_WB, t.p_WB, t.w_WB_B, t.v_WB]) for t in tosses])  # (N, 13)
    offsets = np.concatenate([[0], np.cumsum([len(t) for t in tosses])]).astype(np.int64)
    np.savez(path, states=states, offsets=offsets, toss_id=np.array([t.toss_id for t in tosses], dtype=np.int64), dt=np.array(float(dt)))
    return path
