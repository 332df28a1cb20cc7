"""The one interface every contact predictor answers, and the input checks they share.

    pred = load_predictor("improved" | "paper" | path)       # learned_contact.predictors.loading
    point_A, normal_A = pred.predict(p_AB, R_AB, size_A=size_A, size_B=size_B)
    depth = pred.depth(p_AB, R_AB, size_A=size_A, size_B=size_B)

Frames: A is the first box's body frame (origin at its centre, axes along its edges),
B the second's. p_AB (n, 3) [m] is B's centre in A, R_AB (n, 3, 3) B's orientation in
A; a single pose may be given as (3,) and (3, 3) and is answered with (3,) arrays.
size_A, size_B: full box extents [m], (3,) for all poses or (n, 3) per pose, each one
of the predictor's `supported_sizes` within SIZE_TOLERANCE per axis.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

from learned_contact.errors import PredictorDomainError, PredictorInputError

SIZE_TOLERANCE = 1e-3  # [m] a size matches a supported one within this, per axis
# |R^T R - I| and det R = +1 within this: rotations from quaternions or Drake are
# orthonormal to ~1e-15; 1e-6 admits a matrix stored with 7 significant digits.
ROTATION_TOLERANCE = 1e-6
# Poses answered as trained: separating-axis penetration depth within this range [m].
# Training covers 0 to 0.03 m; 1 cm of separation and 5 cm of depth are tolerated.
DOMAIN_DEPTH = (-0.01, 0.05)
# Outside the domain (outside="clip") the point is clamped into A's box grown by this [m].
CLIP_MARGIN = 0.05


@runtime_checkable
class Predictor(Protocol):
    """What the effects, the gates, the studies and the closed loop may rely on.

    kind: the name recorded in the weights file ("improved", "paper").
    supported_sizes: (k, 3) full extents [m] the predictor answers.
    compiled: True when predict/depth run the native core (learned_contact.compiled),
    False for the numpy reference path.
    """

    kind: str
    supported_sizes: np.ndarray
    compiled: bool

    def predict(self, p_AB, R_AB, *, size_A, size_B, outside: str = "clip"):
        """(point_A (n, 3) [m] in A, normal_A (n, 3) unit, pointing from A into B);
        (3,) each for a single pose. outside="clip" answers poses outside DOMAIN_DEPTH
        with the point clamped into A's box grown by CLIP_MARGIN; "raise" refuses them
        with PredictorDomainError."""
        ...

    def depth(self, p_AB, R_AB, *, size_A, size_B) -> np.ndarray:
        """(n,) separating-axis penetration depth [m] (negative: separated by that much);
        a float for a single pose."""
        ...

    def in_domain(self, p_AB, R_AB, *, size_A, size_B) -> np.ndarray:
        """(n,) bool: the pose's depth lies in DOMAIN_DEPTH (answered as trained)."""
        ...


def check_outside(outside: str) -> None:
    if outside not in ("clip", "raise"):
        raise PredictorInputError(f"outside={outside!r}; expected 'clip' or 'raise'")


def domain_error(depth: np.ndarray) -> PredictorDomainError:
    """The refusal for outside='raise', naming how many poses and the worst depth."""
    out = (depth < DOMAIN_DEPTH[0]) | (depth > DOMAIN_DEPTH[1])
    worst = depth[out][np.argmax(np.abs(depth[out] - np.mean(DOMAIN_DEPTH)))]
    return PredictorDomainError(
        f"{int(out.sum())} of {len(depth)} poses are outside the trained range: penetration depth "
        f"{worst * 100:.1f} cm, expected {DOMAIN_DEPTH[0] * 100:g} to {DOMAIN_DEPTH[1] * 100:g} cm "
        "(negative = separated); use outside='clip' for bounded answers")


def size_error(name: str, bad, supported: np.ndarray, size_range=None) -> PredictorInputError:
    choices = "; ".join(str(tuple(float(v) for v in s)) for s in supported)
    if size_range is not None:
        lo, hi = np.asarray(size_range, dtype=float).reshape(2, 3)
        span = " x ".join(f"{a:g}" if a == b else f"{a:g}-{b:g}" for a, b in zip(lo, hi))
        return PredictorInputError(
            f"{name} {tuple(float(v) for v in bad)} is not a supported container size: outside the supported size "
            f"range; supported: any box of {span} m (length x width x height, full extents)")
    return PredictorInputError(
        f"{name} {tuple(float(v) for v in bad)} is not a supported container size; "
        f"supported (full extents [m]): {choices}")


def in_size_range(size: np.ndarray, size_range) -> np.ndarray:
    """(n,) bool: each size (n, 3) [m] lies inside size_range ((2, 3): lowest, highest full
    extents [m]) within SIZE_TOLERANCE per axis; all False for size_range None."""
    if size_range is None:
        return np.zeros(len(size), dtype=bool)
    lo, hi = np.asarray(size_range, dtype=float).reshape(2, 3)
    return np.all((size >= lo - SIZE_TOLERANCE) & (size <= hi + SIZE_TOLERANCE), axis=1)


def shape_error(p_AB, R_AB) -> PredictorInputError:
    return PredictorInputError(
        f"expected p_AB (n, 3) and R_AB (n, 3, 3) (or (3,) and (3, 3)); got {np.shape(p_AB)} and {np.shape(R_AB)}")


NOT_FINITE = "p_AB and R_AB must be finite (found NaN or inf)"


def check_poses(p_AB, R_AB):
    """(p_AB (n, 3), R_AB (n, 3, 3), single) as contiguous float arrays; raises
    PredictorInputError on bad shapes (finiteness is checked by the caller)."""
    p_AB = np.ascontiguousarray(p_AB, dtype=float)
    R_AB = np.ascontiguousarray(R_AB, dtype=float)
    single = p_AB.ndim == 1
    if single:
        if p_AB.shape != (3,) or R_AB.shape != (3, 3):
            raise shape_error(p_AB, R_AB)
        return p_AB.reshape(1, 3), R_AB.reshape(1, 3, 3), True
    if p_AB.ndim != 2 or p_AB.shape[1] != 3 or R_AB.shape != (len(p_AB), 3, 3):
        raise shape_error(p_AB, R_AB)
    return p_AB, R_AB, False


def check_size_shape(name: str, size, n: int) -> np.ndarray:
    """size as a contiguous (1, 3) or (n, 3) float array; raises on other shapes."""
    size = np.ascontiguousarray(size, dtype=float)
    if size.shape == (3,):
        return size.reshape(1, 3)
    if size.shape != (n, 3):
        raise PredictorInputError(f"{name} must be finite, (3,) or (n, 3); got shape {size.shape}")
    return size


def check_numpy(p_AB, R_AB, size_A, size_B, supported: np.ndarray, size_range=None):
    """The numpy reference path's checks: a size is one of `supported` (k, 3) within
    SIZE_TOLERANCE per axis, or lies inside `size_range` ((2, 3) [m], None: no range).
    Returns (p_AB (n, 3), R_AB (n, 3, 3), size_A (n, 3), size_B (n, 3), single)."""
    p_AB, R_AB, single = check_poses(p_AB, R_AB)
    if not (np.all(np.isfinite(p_AB)) and np.all(np.isfinite(R_AB))):
        raise PredictorInputError(NOT_FINITE)
    check_rotations(R_AB)
    sizes = []
    for name, size in (("size_A", size_A), ("size_B", size_B)):
        size = check_size_shape(name, size, len(p_AB))
        if not np.all(np.isfinite(size)):
            raise PredictorInputError(f"{name} must be finite, (3,) or (n, 3); got {size.tolist()}")
        size = np.broadcast_to(size, p_AB.shape)
        diff = np.abs(size[:, None, :] - supported[None]).max(axis=2).min(axis=1)  # (n,)
        diff[in_size_range(size, size_range)] = 0.0
        if np.any(diff > SIZE_TOLERANCE):
            raise size_error(name, size[np.argmax(diff)], supported, size_range)
        sizes.append(np.ascontiguousarray(size))
    return p_AB, R_AB, sizes[0], sizes[1], single


def rotation_error(row: int, R) -> PredictorInputError:
    R = np.asarray(R, dtype=float)
    off = float(np.max(np.abs(R.T @ R - np.eye(3))))
    return PredictorInputError(
        f"R_AB[{row}] is not a rotation matrix: max |R^T R - I| = {off:.3g}, det = {np.linalg.det(R):.6g}; "
        f"expected an orthonormal matrix with det +1 (within {ROTATION_TOLERANCE:g})")


def check_rotations(R_AB) -> None:
    """Raises PredictorInputError for the first R_AB (n, 3, 3) that is not a proper rotation."""
    off = np.abs(np.einsum("nki,nkj->nij", R_AB, R_AB) - np.eye(3)).max(axis=(1, 2))
    bad = (off > ROTATION_TOLERANCE) | (np.linalg.det(R_AB) < 0.0)
    if np.any(bad):
        row = int(np.argmax(bad))
        raise rotation_error(row, R_AB[row])


def raise_for_status(status: int, row: int, p_AB, size_A, size_B, supported, R_AB=None, size_range=None) -> None:
    """Turns a compiled kernel's status (learned_contact.compiled.STATUS_*) into the
    same errors the numpy path raises."""
    if status == 1:
        raise PredictorInputError(NOT_FINITE)
    if status == 6:
        raise rotation_error(row, R_AB[row] if R_AB is not None else np.full((3, 3), np.nan))
    name, size = ("size_A", size_A) if status in (2, 4) else ("size_B", size_B)
    bad = size[row if len(size) > 1 else 0]
    if status in (4, 5):
        raise PredictorInputError(f"{name} must be finite, (3,) or (n, 3); got {bad.tolist()}")
    raise size_error(name, bad, supported, size_range)
