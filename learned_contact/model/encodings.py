"""Pose canonicalisation and input/output encodings (pure numpy).

Symmetry reduction (the paper's trihedron reduction, generalised): a box is symmetric
under the 8 reflections diag(+-1, +-1, +-1) of its own frame, and so is the contact
answer. We reflect A's frame by S = diag(sign(p_AB)) so that B's centre lies in A's
positive octant (the convex trihedron of A facing B); B's axes, defined up to sign, get
their signs chosen by a fixed rule. Answers computed in the canonical frame are
mapped back by S (S is its own inverse).

The paper's 4 outputs are spherical angles (azimuth in [-pi, pi], elevation in
[-pi/2, pi/2]) of the contact point direction (from A's centre) and of the force
direction, both in the canonical frame. The paper does not give its polar axis; we use
PAPER_FRAME: polar axis (1, -1, 0)/sqrt(2), azimuth zero along (1, 1, 1)/sqrt(3). Every
direction in the positive octant is at least 45 deg from both poles and 125 deg from the
azimuth seam, so in the canonical frame the outputs are continuous (the paper's
"model without discontinuities", Table 2).
"""

from __future__ import annotations

import numpy as np

from learned_contact.model.prior import patch_estimate
from testbed.geometry.boxes import CORNER_SIGNS

_E1 = np.array([1.0, 1.0, 1.0]) / np.sqrt(3.0)  # azimuth zero
_POLE = np.array([1.0, -1.0, 0.0]) / np.sqrt(2.0)
_E2 = np.cross(_POLE, _E1)
PAPER_FRAME = np.stack([_E1, _E2, _POLE])  # rows: x', y', z' of the spherical frame


def octant_signs(p_AB) -> np.ndarray:
    """(n, 3) the diagonal of S: +1 where p_AB >= 0, else -1."""
    return np.where(np.asarray(p_AB) >= 0.0, 1.0, -1.0)


def canonicalise(p_AB, R_AB):
    """Reflects poses into A's positive octant.

    Returns (S (n, 3) diagonal signs, p_c (n, 3) >= 0 [m], R_c (n, 3, 3)): R_c's columns
    are B's axes in the canonical frame, each with the sign that makes its sum
    non-negative (a box is symmetric under axis flips, so any sign is the same box);
    R_c may be improper.
    """
    S = octant_signs(p_AB)
    return (S, *reflect(S, p_AB, R_AB))


def reflect(sigma, p_AB, R_AB):
    """(p (n, 3) [m], R (n, 3, 3)): poses seen in A's frame reflected by diag(sigma)
    (sigma (n, 3) of +-1), B's columns sign-fixed as in canonicalise."""
    p = sigma * p_AB
    R = sigma[:, :, None] * R_AB
    col = np.where(R.sum(axis=1) >= 0.0, 1.0, -1.0)  # (n, 3)
    return p, R * col[:, None, :]


# ------------------------------------------------------- continuity on the octant planes
# The improved predictor answers in the octant frame S = diag(sign(p_AB)); on a plane
# p_k = 0 the two octants meet and a network that is not exactly symmetric there jumps.
# Within SYMMETRY_BAND of a plane the answer is blended with the same pose answered in
# the neighbouring octant's frame (S with its k-th sign flipped): weight 1 - w/2 on the
# own frame and w/2 on the other, w = band_weight(|p_k|) (1 on the plane, 0 beyond the
# band, C1). On the plane both frames get 1/2 from either side, so the answer is
# continuous there by construction (to rounding); near two or three planes the blends
# nest (product weights over the 4 or 8 frames). Beyond every band it is the plain
# canonical answer, bit for bit.
SYMMETRY_BAND = 0.02  # [m]
FLIPS = ((0, 0, 0), (0, 0, 1), (0, 1, 0), (0, 1, 1), (1, 0, 0), (1, 0, 1), (1, 1, 0), (1, 1, 1))


def band_weight(t) -> np.ndarray:
    """w(t) = 1 - smoothstep(t / SYMMETRY_BAND) for t = |p_k| [m]: 1 at 0, 0 from the
    band's edge on, with zero slope at both ends."""
    u = np.clip(np.asarray(t) / SYMMETRY_BAND, 0.0, 1.0)
    return 1.0 - u * u * (3.0 - 2.0 * u)


def frame_blend(p_AB):
    """[(sigma (n, 3) frame signs, coef (n,) weight)] for the FLIPS of the octant frame
    (own frame first; coefficients sum to 1 per pose, zero outside the bands), leaving
    out the flips whose weight is zero for every pose."""
    S = octant_signs(p_AB)
    half = 0.5 * band_weight(np.abs(p_AB))  # (n, 3)
    out = []
    near = np.any(half > 0.0, axis=0)  # (3,) any pose inside the band of plane k
    for flip in FLIPS:
        if any(f and not near[k] for k, f in enumerate(flip)):
            continue  # weight 0 for every pose: not evaluated
        coef = np.ones(len(S))
        for k in range(3):
            coef = coef * (half[:, k] if flip[k] else 1.0 - half[:, k])
        out.append((S * np.where(np.array(flip) == 1, -1.0, 1.0), coef))
    return out


def proper(R_c) -> np.ndarray:
    """(n, 3, 3) a proper rotation describing the same box: flips the third column where
    det < 0 (used where Euler angles are needed)."""
    det = np.linalg.det(R_c)
    out = R_c.copy()
    out[:, :, 2] *= np.where(det < 0.0, -1.0, 1.0)[:, None]
    return out


def spherical(v) -> np.ndarray:
    """(n, 2) [azimuth, elevation] [rad] of vectors v (n, 3) in PAPER_FRAME."""
    w = np.asarray(v) @ PAPER_FRAME.T
    az = np.arctan2(w[:, 1], w[:, 0])
    el = np.arctan2(w[:, 2], np.hypot(w[:, 0], w[:, 1]))
    return np.stack([az, el], axis=1)


def from_spherical(angles) -> np.ndarray:
    """(n, 3) unit vectors from (n, 2) [azimuth, elevation] in PAPER_FRAME."""
    az, el = angles[:, 0], angles[:, 1]
    w = np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], axis=1)
    return w @ PAPER_FRAME


def paper_outputs(point_A, normal_A, S) -> np.ndarray:
    """(n, 4) the paper's outputs [az_point, el_point, az_force, el_force] [rad] of a
    contact point (n, 3) [m] and unit normal (n, 3) in A's frame, given the octant
    signs S (n, 3) of the pose."""
    return np.concatenate([spherical(S * point_A), spherical(S * normal_A)], axis=1)


def angle_error(pred, true) -> np.ndarray:
    """Signed error pred - true [rad], wrapped into [-pi, pi)."""
    return (np.asarray(pred) - np.asarray(true) + np.pi) % (2 * np.pi) - np.pi


# ---------------------------------------------------------------- improved features
def features(p_c, R_c, h_A, h_B, *, with_overlap: bool = False):
    """Fixed-cost inputs of the improved model, from a canonical pose.

    p_c (n, 3) [m], R_c (n, 3, 3), h_A, h_B (n, 3) half extents [m].
    Returns (x (n, N_FEATURES), point_est (n, 3) [m], normal_est (n, 3)): the
    geometric estimate (geometry.patch_estimate) that the model corrects, in the
    canonical frame. Lengths in x are multiplied by LENGTH_SCALE [1/m]. Blocks of x:
    p_c (3), h_A (3), h_B (3), b_j b_j^T of B's axes (18, sign invariant), the 15
    separating-axis overlaps (15, clipped), the estimate's normal (3) and point (3),
    its patch volume (1), depth (1), edge-axis flag (1), B's corners (24) and their
    depth inside A (8), A's corners' depth inside B (8). with_overlap: a fourth array,
    the 15 separating-axis overlaps (n, 15) [m] unclipped (the slab scale's faces,
    learned_contact.model.expert.slab_axes).
    """
    n = len(p_c)
    s = LENGTH_SCALE
    outer = np.swapaxes(R_c, 1, 2)[:, :, :, None] * np.swapaxes(R_c, 1, 2)[:, :, None, :]  # (n, 3 axes, 3, 3)
    iu = np.triu_indices(3)
    outer = outer[:, :, iu[0], iu[1]].reshape(n, 18)
    point_est, n_est, depth, k, weight, overlap = patch_estimate(p_c, R_c, h_A, h_B)
    corners_B = p_c[:, None, :] + (CORNER_SIGNS[None] * h_B[:, None, :]) @ np.swapaxes(R_c, 1, 2)
    depth_B = np.min(h_A[:, None, :] - np.abs(corners_B), axis=2)  # (n, 8) >0 inside A
    corners_A = CORNER_SIGNS[None] * h_A[:, None, :]  # (n, 8, 3) in A
    in_B = (corners_A - p_c[:, None, :]) @ R_c  # A's corners in B
    depth_A = np.min(h_B[:, None, :] - np.abs(in_B), axis=2)
    x = np.concatenate(
        [p_c * s, h_A * s, h_B * s, outer, np.minimum(overlap, 0.5) * 10.0, n_est, point_est * s,
         np.log10(weight + 1e-9)[:, None], depth[:, None] * 30.0, (k >= 6)[:, None].astype(float),
         corners_B.reshape(n, 24) * s, np.clip(depth_B, -0.5, 0.5) * 10.0,
         np.clip(depth_A, -0.5, 0.5) * 10.0],
        axis=1,
    )
    return (x, point_est, n_est, overlap) if with_overlap else (x, point_est, n_est)


LENGTH_SCALE = 1.0 / 6.0
N_FEATURES = 3 + 3 + 3 + 18 + 15 + 3 + 3 + 3 + 24 + 8 + 8
