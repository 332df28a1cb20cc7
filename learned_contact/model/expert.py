"""The resting expert's gate: which poses the improved predictor's second network answers.

The main network is trained on depths uniform in 0-3 cm; where stacks rest at the 1e9 Pa
modulus (overlaps of micrometres, tilts of hundredths of a degree) it moves the point
centimetres from Drake's answer. The resting expert is a network of the same
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
- x, y: B's horizontal offset along A's x and y, per axis.

Two layouts of the bounds (`expert/domain` in the weights file; the layout is told by its
length):

- DOMAIN_FIELDS (11 values, format_version 3): the offsets are fractions of the
  edge of support, u_i = |p_c,i| / e_i with e_i = max(h_A,i, h_B,i) (half extents [m]):
  whichever box lies on the other, its centre of mass leaves the other's face where
  |p_i| reaches the lower box's half extent, so beyond max(h_A,i, h_B,i) neither can rest
  on the other alone and u_i = 1 is the edge of support along axis i. Separate bounds
  for x (A's length: overhangs, a 20 ft box at the end of a 40 ft one at u_x = 0.5, a
  40 ft box across two 20 ft ones at u_x = 0.5) and y, so opening the gate along the
  length no longer opens it across. A box beside A (side contact) has u_i >= 1.5.
- DOMAIN_FIELDS_V2 (9 values, format_version 2): one offset bound [m] for both
  |p_c,x| and |p_c,y|; files of it load and answer as before.

The inner bounds hold the training distributions' core (g = 1 there), the outer bounds
stay inside what the expert was trained on (ramps included), so the expert is trained
wherever g > 0 (training.train.default_domain, expert_domain).
Elsewhere (g = 0) the answer is the main network's, bit for bit; each network is
evaluated only where its weight is not 0. A crane landing, a deep stack or a box beside
A never reach the expert.

Where the geometric prior is exact the correction vanishes by construction, everywhere,
not only inside the gate. Where B's face is parallel to A's (a level face on
a face, any yaw, any offset, any pair of faces) the overlap is a slab of one depth, and
the prior's depth-weighted patch centroid is Drake's centre of pressure (measured: under
0.01 mm); a network, however trained, answers it to about a millimetre or worse (the main
network: 3.2 cm). The slab ratio r = (height range of B's face over the footprint both
boxes share, from its tilt) / depth says how far a pose is from a slab (slab_ratio, on
the faces that meet: slab_axes), and every correction is scaled by s = smoothstep(r / r_slab):

    y = s ((1 - g) main(x) + g expert(x))

so at r = 0 the answer is the prior's exactly (every octant frame, every path), and from
r_slab on it is the networks' as before. The hand-over is C1 in r; r is continuous in the
pose except where the prior's reference face changes (the prior itself switches there).
Before format_version 3 the scale applied inside the gate only (c = 1 - g (1 - s)): the two agree
where g = 1 and wherever r >= r_slab; only poses with r < r_slab outside the gate or in its
ramps are answered differently (closer to the prior).

The bounds travel in the weights file (`expert/domain`, DOMAIN_FIELDS order), so a file
declares where its expert answers.
"""

from __future__ import annotations

import numpy as np

# format_version 3: offsets per axis as fractions of the edge of support (module docstring)
DOMAIN_FIELDS = ("depth_in [m]", "depth_out [m]", "sin_tilt_in", "sin_tilt_out", "sin_yaw_in", "sin_yaw_out",
                 "support_x_in", "support_x_out", "support_y_in", "support_y_out", "r_slab")
# format_version 2: one offset bound [m] for both |p_c,x| and |p_c,y|
DOMAIN_FIELDS_V2 = ("depth_in [m]", "depth_out [m]", "sin_tilt_in", "sin_tilt_out", "sin_yaw_in", "sin_yaw_out",
                    "offset_in [m]", "offset_out [m]", "r_slab")
LAYOUTS = {2: DOMAIN_FIELDS_V2, 3: DOMAIN_FIELDS}  # format_version -> the fields of its expert/domain
# the slab ratio from which the expert's correction is whole (measured: the prior's median error
# is 0.3 mm for r in 0.001-0.01 and 1.6 mm for r in 0.01-0.03; learned_contact/RESEARCH_LOG.md)
R_SLAB = 0.01


def layout(domain) -> tuple[str, ...]:
    """The fields of a gate's bounds by their number: DOMAIN_FIELDS (11) or DOMAIN_FIELDS_V2 (9)."""
    n = len(domain)
    for fields in LAYOUTS.values():
        if len(fields) == n:
            return fields
    raise ValueError(f"a gate of {n} values; expected {len(DOMAIN_FIELDS)} (DOMAIN_FIELDS) or "
                     f"{len(DOMAIN_FIELDS_V2)} (DOMAIN_FIELDS_V2)")


def check_domain(domain, version: int = 3) -> str | None:
    """None if `domain` is a valid gate of format_version `version`'s layout (LAYOUTS: all
    values finite, 0 <= inner < outer per pair, r_slab > 0), else what is wrong with it."""
    fields = LAYOUTS[version]
    d = np.asarray(domain, dtype=float)
    if d.shape != (len(fields),):
        return f"has shape {d.shape}, expected ({len(fields)},) for format_version {version}"
    if not np.all(np.isfinite(d)):
        return "holds NaN or inf"
    for k in range((len(fields) - 1) // 2):
        if not 0.0 <= d[2 * k] < d[2 * k + 1]:
            return f"{fields[2 * k]} = {d[2 * k]} and {fields[2 * k + 1]} = {d[2 * k + 1]}: expected 0 <= in < out"
    if not d[-1] > 0.0:
        return f"r_slab = {d[-1]}: expected > 0"
    return None


def support(p_c, h_A, h_B) -> np.ndarray:
    """(n, 2) u = |p_c,i| / max(h_A,i, h_B,i) for i = x, y: B's offset from A's centre as a
    fraction of the edge of support (module docstring); p_c (n, 3) [m], half extents
    h_A, h_B (n, 3) [m]."""
    return np.abs(p_c[:, :2]) / np.maximum(h_A[:, :2], h_B[:, :2])


def _ramp_off(t, t_in, t_out):
    """1 for t <= t_in, 0 for t >= t_out, smoothstep (C1) between."""
    u = np.clip((t - t_in) / (t_out - t_in), 0.0, 1.0)
    return 1.0 - u * u * (3.0 - 2.0 * u)


def gate(p_c, R_c, depth, domain, h_A=None, h_B=None) -> np.ndarray:
    """(n,) the expert's weight g in [0, 1] for canonical poses p_c (n, 3) [m], R_c
    (n, 3, 3) (columns: B's axes in A's reflected frame), separating-axis depth (n,) [m];
    domain: DOMAIN_FIELDS (then half extents h_A, h_B (n, 3) [m] are needed) or
    DOMAIN_FIELDS_V2 (absolute offsets)."""
    d = np.asarray(domain, dtype=float)
    sin_tilt = np.hypot(R_c[:, 0, 2], R_c[:, 1, 2])
    g = _ramp_off(depth, d[0], d[1]) * _ramp_off(sin_tilt, d[2], d[3]) * _ramp_off(np.abs(R_c[:, 1, 0]), d[4], d[5])
    if layout(d) is DOMAIN_FIELDS_V2:
        return g * _ramp_off(np.abs(p_c[:, 0]), d[6], d[7]) * _ramp_off(np.abs(p_c[:, 1]), d[6], d[7])
    if h_A is None or h_B is None:
        raise ValueError("a DOMAIN_FIELDS gate needs the half extents h_A and h_B")
    u = support(p_c, h_A, h_B)
    return g * _ramp_off(u[:, 0], d[6], d[7]) * _ramp_off(u[:, 1], d[8], d[9])


def slab_axes(R_c, overlap) -> tuple[np.ndarray, np.ndarray]:
    """((n,) k, (n,) j): the axis pair whose faces meet, from the prior's reference face
    (geometry.patch_estimate: the face axis of least overlap among overlap[:, :6], A's
    three then B's three). A's face k: j = B's axis most aligned with A's k; B's face j:
    k = A's axis most aligned with B's j. R_c (n, 3, 3) (columns: B's axes in A's
    canonical frame), overlap (n, 15) [m] the separating-axis overlaps."""
    face = np.argmin(overlap[:, :6], axis=1)
    a = np.abs(R_c)
    rows = np.arange(len(face))
    on_A = face < 3
    k = np.where(on_A, face, np.argmax(a[rows, :, face % 3], axis=1))
    j = np.where(on_A, np.argmax(a[rows, face % 3, :], axis=1), face - 3)
    return k, j


def slab_ratio(R_c, h_A, h_B, depth, axes=None) -> np.ndarray:
    """(n,) r = (height range of B's face over the footprint both boxes share, from its
    tilt) / depth, for the faces that meet: A's face axis k and B's axis j (`axes`, the
    pair of `slab_axes`; default A's z and B's z, a stack on A's top face):

        r = 2 sum_{i != k} |R_c[i, j]| min(h_A,i, h_B,m(i)) / depth,

    m(i) = B's axis other than j most aligned with A's i, h half extents (n, 3) [m],
    depth (n,) [m]. 0 exactly where B's face is parallel to A's (B's axis j along A's
    k to float precision: a level face on a face, any yaw and offset), inf where
    depth <= 0. On a stack (k = j = z, B's x nearest A's x) this is
    2 (|z_B,x| min(h_A,x, h_B,x) + |z_B,y| min(h_A,y, h_B,y)) / depth."""
    n = len(R_c)
    k, j = (np.full(n, 2), np.full(n, 2)) if axes is None else axes
    rows = np.arange(n)
    a = np.abs(R_c)
    rise = np.zeros(n)
    for i in range(3):
        others = a[rows, i, :].copy()
        others[rows, j] = -1.0
        m = np.argmax(others, axis=1)
        term = a[rows, i, j] * np.minimum(h_A[:, i], h_B[rows, m])
        rise = rise + np.where(k == i, 0.0, term)
    rise = 2.0 * rise
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(depth > 0.0, rise / np.where(depth > 0.0, depth, 1.0), np.inf)


def weights(p_c, R_c, h_A, h_B, depth, domain, overlap=None) -> tuple[np.ndarray, np.ndarray]:
    """(w_main (n,), w_expert (n,)): the weights of the main network's and the expert's
    correction, w_main = (1 - g) s, w_expert = g s (module docstring); s is the slab
    scale (smoothstep(slab_ratio / r_slab) with domain's r_slab, its last value; on A's top
    face when `overlap` is None). p_c (n, 3) [m], R_c (n, 3, 3), half extents h_A, h_B (n, 3)
    [m], depth (n,) [m], overlap (n, 15) [m]; domain: either layout (`gate`), or None: no
    expert (g = 0, r_slab = R_SLAB)."""
    if domain is None:
        g, r_slab = np.zeros(len(R_c)), R_SLAB
    else:
        d = np.asarray(domain, dtype=float)
        g, r_slab = gate(p_c, R_c, depth, d, h_A, h_B), d[-1]
    axes = None if overlap is None else slab_axes(R_c, overlap)
    s = 1.0 - _ramp_off(slab_ratio(R_c, h_A, h_B, depth, axes), 0.0, r_slab)
    return (1.0 - g) * s, g * s
