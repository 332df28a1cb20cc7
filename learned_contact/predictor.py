"""The improved contact predictor: pure-numpy inference (no torch import).

    pred = load_predictor()                      # shipped default
    point_A, normal_A = pred.predict(p_AB, R_AB, size_A=size_A, size_B=size_B)

Pipeline (fixed cost per pair): canonicalise the pose into A's positive octant
(encodings.canonicalise), compute the geometric estimate and features
(encodings.features), let the MLP correct the estimate (point += POINT_STEP * y[:3],
normal = normalise(estimate + y[3:6])), reflect back.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np

from learned_contact.encodings import canonicalise, features
from learned_contact.errors import PredictorDomainError, PredictorInputError, WeightsError
from learned_contact.geometry import sat_normal
from learned_contact.mlp import NumpyMLP

SHIPPED_DIR = Path(__file__).resolve().parent / "shipped"
DEFAULT_WEIGHTS = SHIPPED_DIR / "weights.npz"
FORMAT_VERSION = 1
POINT_STEP = 0.5  # [m] per unit of the MLP's point outputs
SIZE_TOLERANCE = 1e-3  # [m] a size matches a supported one within this, per axis
# Poses answered as trained: separating-axis penetration depth within this range [m].
# Training covers 0 to 0.03 m; 1 cm of separation and 5 cm of depth are tolerated.
DOMAIN_DEPTH = (-0.01, 0.05)
# Outside the domain (outside="clip") the point is clamped into A's box grown by this [m].
CLIP_MARGIN = 0.05


@dataclasses.dataclass(frozen=True)
class ContactPredictor:
    """Predicts the static hydroelastic contact answer of a container pair.

    mlp: the correction network; supported_sizes (k, 3): full extents [m] it was
    trained for; meta: training config and provenance (JSON-able dict).
    """

    mlp: NumpyMLP
    supported_sizes: np.ndarray
    meta: dict

    def depth(self, p_AB, R_AB, *, size_A, size_B) -> np.ndarray:
        """(n,) separating-axis penetration depth [m] (negative = separated by that much)."""
        p_AB, R_AB, size_A, size_B, _ = self._check(p_AB, R_AB, size_A, size_B)
        return sat_normal(p_AB, R_AB, 0.5 * size_A, 0.5 * size_B)[1]

    def in_domain(self, p_AB, R_AB, *, size_A, size_B) -> np.ndarray:
        """(n,) bool: whether each pose lies in the range answered as trained (DOMAIN_DEPTH)."""
        d = self.depth(p_AB, R_AB, size_A=size_A, size_B=size_B)
        return (d >= DOMAIN_DEPTH[0]) & (d <= DOMAIN_DEPTH[1])

    def predict(self, p_AB, R_AB, *, size_A, size_B, outside: str = "clip"):
        """Contact point and normal for B at (p_AB, R_AB) in A's frame.

        p_AB (n, 3) or (3,): B's centre in A's frame [m]; R_AB (n, 3, 3) or (3, 3):
        B's orientation in A; size_A, size_B (3,) or (n, 3): full box extents [m],
        each one of the supported container sizes.
        Returns (point_A (n, 3) [m] in A's frame, normal_A (n, 3) unit, A towards B);
        (3,) each when a single pose was given. Raises PredictorInputError for bad
        shapes, non-finite values or unsupported sizes.

        Poses outside the trained range (separating-axis depth outside DOMAIN_DEPTH:
        separated boxes, deep penetration) are answered within a documented bound when
        outside="clip" (the default): the point is clamped into A's box grown by
        CLIP_MARGIN and the normal is a unit vector (the separating-axis normal where
        the network's is degenerate). outside="raise" refuses them with
        PredictorDomainError instead. Use `in_domain` to know which answers are trained.
        """
        if outside not in ("clip", "raise"):
            raise PredictorInputError(f"outside={outside!r}; expected 'clip' or 'raise'")
        p_AB, R_AB, size_A, size_B, single = self._check(p_AB, R_AB, size_A, size_B)
        h_A = 0.5 * size_A
        sat_n, depth, _ = sat_normal(p_AB, R_AB, h_A, 0.5 * size_B)
        out = (depth < DOMAIN_DEPTH[0]) | (depth > DOMAIN_DEPTH[1])
        if outside == "raise" and np.any(out):
            worst = depth[out][np.argmax(np.abs(depth[out] - np.mean(DOMAIN_DEPTH)))]
            raise PredictorDomainError(
                f"{int(out.sum())} of {len(depth)} poses are outside the trained range: penetration depth "
                f"{worst * 100:.1f} cm, expected {DOMAIN_DEPTH[0] * 100:g} to {DOMAIN_DEPTH[1] * 100:g} cm "
                "(negative = separated); use outside='clip' for bounded answers")
        S, p_c, R_c = canonicalise(p_AB, R_AB)
        x, point_est, normal_est = features(p_c, R_c, h_A, 0.5 * size_B)
        y = self.mlp(x)
        point = S * (point_est + POINT_STEP * y[:, :3])
        normal = S * (normal_est + y[:, 3:6])
        length = np.linalg.norm(normal, axis=1, keepdims=True)
        ok = np.isfinite(length) & (length > 1e-9)
        normal = np.where(ok, normal / np.where(ok, length, 1.0), sat_n)
        if np.any(out):
            bound = h_A + CLIP_MARGIN
            point = np.where(out[:, None], np.clip(point, -bound, bound), point)
        return (point[0], normal[0]) if single else (point, normal)

    def _check(self, p_AB, R_AB, size_A, size_B):
        p_AB = np.asarray(p_AB, dtype=float)
        R_AB = np.asarray(R_AB, dtype=float)
        single = p_AB.ndim == 1
        if single:
            p_AB, R_AB = p_AB[None], R_AB[None]
        if p_AB.ndim != 2 or p_AB.shape[1] != 3 or R_AB.shape != (len(p_AB), 3, 3):
            raise PredictorInputError(
                f"expected p_AB (n, 3) and R_AB (n, 3, 3) (or (3,) and (3, 3)); got "
                f"{np.shape(p_AB)} and {np.shape(R_AB)}")
        if not (np.all(np.isfinite(p_AB)) and np.all(np.isfinite(R_AB))):
            raise PredictorInputError("p_AB and R_AB must be finite (found NaN or inf)")
        sizes = []
        for name, size in (("size_A", size_A), ("size_B", size_B)):
            size = np.asarray(size, dtype=float)
            if size.shape == (3,):
                size = np.broadcast_to(size, p_AB.shape)
            if size.shape != p_AB.shape or not np.all(np.isfinite(size)):
                raise PredictorInputError(f"{name} must be finite, (3,) or (n, 3); got shape {np.shape(size)}")
            diff = np.abs(size[:, None, :] - self.supported_sizes[None]).max(axis=2)  # (n, k)
            if np.any(diff.min(axis=1) > SIZE_TOLERANCE):
                bad = size[np.argmax(diff.min(axis=1))]
                choices = "; ".join(str(tuple(float(v) for v in s)) for s in self.supported_sizes)
                raise PredictorInputError(
                    f"{name} {tuple(float(v) for v in bad)} is not a supported container size; "
                    f"supported (full extents [m]): {choices}")
            sizes.append(np.ascontiguousarray(size))
        return p_AB, R_AB, sizes[0], sizes[1], single

    def save(self, path) -> Path:
        """Writes the predictor to an .npz file (weights, sizes, meta as JSON)."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        np.savez(path, format_version=np.array(FORMAT_VERSION), supported_sizes=self.supported_sizes,
                 meta=np.array(json.dumps(self.meta)), **self.mlp.to_arrays("mlp/"))
        return path


def load_predictor(path=None) -> ContactPredictor:
    """The predictor stored at `path` (.npz), or the shipped default when None."""
    path = Path(path) if path is not None else DEFAULT_WEIGHTS
    if not path.is_file():
        raise WeightsError(f"weights file {path} not found; train one with learned_contact.training.train_default")
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {k: data[k] for k in data.files}
    except Exception as exc:  # noqa: BLE001 - any unreadable file is the same error
        raise WeightsError(f"cannot read weights file {path}: {exc}") from exc
    version = int(arrays.get("format_version", -1))
    if version != FORMAT_VERSION:
        raise WeightsError(f"weights file {path} has format version {version}; expected {FORMAT_VERSION}")
    return ContactPredictor(
        mlp=NumpyMLP.from_arrays(arrays, "mlp/"),
        supported_sizes=np.asarray(arrays["supported_sizes"], dtype=float),
        meta=json.loads(str(arrays["meta"])),
    )
