"""The resting expert's gate: which poses the improved predictor's second network answers.

The main network is trained on depths uniform in 0-3 cm; where stacks rest at the 1e9 Pa
modulus (overlaps of micrometres, tilts of hundredths of a degree) it moves the point
centimetres from Drake's answer (issue 20). The resting expert is a network of the same
shape and features, trained only on that regime (sampling's "resting", "resting_wide" and
"resting_level" distributions) with its own input standardisation, so that micrometre depths are no
longer lost in features scaled for centimetres. A gate hands it the poses of its domain:

    y = (1 - g) * main(x) + g * expert(x),   g = g_depth * g_tilt * g_yaw * g_x * g_y

each factor a C1 ramp (smoothstep) from 1 at its inner bound to 0 at its outer bound, of
quantities of the canonical pose (all absolute values, so every octant frame of one pose
gets the same g):

- depth: the separating-axis penetration [m];
- tilt: |B's z axis in A's xy plane| = sin(the angle between B's z and A's z);
- yaw: |B's x axis along A's y| (about sin of the yaw);
- x, y: |B's centre along A's x and y| [m] (the horizontal offset).

The inner bounds hold the whole "resting" distribution (g = 1 on every one of its poses);
the outer bounds stay inside "resting_wide", so the expert is trained wherever g > 0.
Elsewhere (g = 0) the answer is the main network's, bit for bit; each network is
evaluated only where its weight is not 0. A crane landing, a deep stack or B far off
A's centre (the overhang scenes) never reach the expert.

Where the geometric prior is exact the correction vanishes by construction. On a level
stack the overlap is a slab of one depth, and the prior's depth-weighted patch centroid
is Drake's centre of pressure (measured: 0.004 mm median); a network, however trained,
answers it to about a millimetre. The slab ratio r = (height range of B's bottom face
over the footprint both boxes share, from its tilt) / depth says how far a pose is from
a slab, and inside the gate the correction is scaled by s = smoothstep(r / r_slab):

    y = (1 - g) * c * main(x) + g * c * expert(x),   c = 1 - g * (1 - s)

so at r = 0 (and g = 1) the answer is the prior's exactly, and from r_slab on it is the
expert's. Where g = 0, c = 1.

The bounds travel in the weights file (`expert/domain`, DOMAIN_FIELDS order), so a file
declares where its expert answers.
"""

from __future__ import annotations

import numpy as np

from learned_contact.sampling import RESTING_RANGES

DOMAIN_FIELDS = ("depth_in [m]", "depth_out [m]", "sin_tilt_in", "sin_tilt_out", "sin_yaw_in", "sin_yaw_out",
                 "offset_in [m]", "offset_out [m]", "r_slab")
# the slab ratio from which the expert's correction is whole (measured: the prior's median error
# is 0.3 mm for r in 0.001-0.01 and 1.6 mm for r in 0.01-0.03; learned_contact/README.md)
R_SLAB = 0.01


def default_domain() -> np.ndarray:
    """(9,) the gate's bounds (DOMAIN_FIELDS) from sampling's resting ranges: inner =
    "resting" (roll and pitch each within t make a tilt up to sqrt(2) t; 1 % margins on
    tilt and yaw, 10 % on depth for the labeller's 1 um bisection), outer = "resting_wide"
    (its roll and pitch square holds the disc of radius t); then R_SLAB."""
    (_, d_in), tilt_in, yaw_in, off_in = RESTING_RANGES["resting"]
    (_, d_out), tilt_out, yaw_out, off_out = RESTING_RANGES["resting_wide"]
    s = lambda deg: float(np.sin(np.radians(deg)))  # noqa: E731
    return np.array([1.1 * d_in, d_out, s(1.01 * np.sqrt(2.0) * tilt_in), s(tilt_out), s(1.01 * yaw_in), s(yaw_out),
                     off_in, off_out, R_SLAB])


def check_domain(domain) -> str | None:
    """None if `domain` is a valid gate (9 finite values, 0 <= inner < outer per pair,
    r_slab > 0), else what is wrong with it."""
    d = np.asarray(domain, dtype=float)
    if d.shape != (len(DOMAIN_FIELDS),):
        return f"has shape {d.shape}, expected ({len(DOMAIN_FIELDS)},)"
    if not np.all(np.isfinite(d)):
        return "holds NaN or inf"
    for k in range(4):
        if not 0.0 <= d[2 * k] < d[2 * k + 1]:
            return f"{DOMAIN_FIELDS[2 * k]} = {d[2 * k]} and {DOMAIN_FIELDS[2 * k + 1]} = {d[2 * k + 1]}: expected 0 <= in < out"
    if not d[8] > 0.0:
        return f"r_slab = {d[8]}: expected > 0"
    return None


def _ramp_off(t, t_in, t_out):
    """1 for t <= t_in, 0 for t >= t_out, smoothstep (C1) between."""
    u = np.clip((t - t_in) / (t_out - t_in), 0.0, 1.0)
    return 1.0 - u * u * (3.0 - 2.0 * u)


def gate(p_c, R_c, depth, domain) -> np.ndarray:
    """(n,) the expert's weight g in [0, 1] for canonical poses p_c (n, 3) [m], R_c
    (n, 3, 3) (columns: B's axes in A's reflected frame), separating-axis depth (n,) [m]."""
    d = np.asarray(domain, dtype=float)
    sin_tilt = np.hypot(R_c[:, 0, 2], R_c[:, 1, 2])
    return (_ramp_off(depth, d[0], d[1]) * _ramp_off(sin_tilt, d[2], d[3]) * _ramp_off(np.abs(R_c[:, 1, 0]), d[4], d[5])
            * _ramp_off(np.abs(p_c[:, 0]), d[6], d[7]) * _ramp_off(np.abs(p_c[:, 1]), d[6], d[7]))


def slab_ratio(R_c, h_A, h_B, depth) -> np.ndarray:
    """(n,) r = (height range of B's bottom face over the footprint both boxes share) /
    depth: 2 (|z_B,x| min(h_A,x, h_B,x) + |z_B,y| min(h_A,y, h_B,y)) / depth, with z_B
    B's z axis in the canonical frame and h half extents [m]; 0 on a level stack, inf
    where depth <= 0 (meaningful inside the gate, where B rests on A's top face)."""
    rise = 2.0 * (np.abs(R_c[:, 0, 2]) * np.minimum(h_A[:, 0], h_B[:, 0])
                  + np.abs(R_c[:, 1, 2]) * np.minimum(h_A[:, 1], h_B[:, 1]))
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(depth > 0.0, rise / np.where(depth > 0.0, depth, 1.0), np.inf)


def weights(p_c, R_c, h_A, h_B, depth, domain) -> tuple[np.ndarray, np.ndarray]:
    """(w_main (n,), w_expert (n,)): the weights of the main network's and the expert's
    correction (module docstring: w_main = (1 - g) c, w_expert = g c); w_main is exactly 1
    where the gate is shut."""
    d = np.asarray(domain, dtype=float)
    g = gate(p_c, R_c, depth, d)
    s = 1.0 - _ramp_off(slab_ratio(R_c, h_A, h_B, depth), 0.0, d[8])
    c = 1.0 - g * (1.0 - s)
    return (1.0 - g) * c, g * c
