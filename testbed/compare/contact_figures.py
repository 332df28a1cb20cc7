"""Figures of a candidate's contact against the reference's (testbed/compare/run_candidates.py).

SatDepth: the separating-axis depth every candidate's penetration is measured with;
contact_figures: a candidate's contact rows (one per touching body pair per step, the
Engine protocol's shape, testbed/engines/base.py) against Drake's centre of pressure and
normal of the same step and pair.
"""

from __future__ import annotations

import numpy as np

from testbed.geometry.boxes import box_box_signed_distance
from testbed.geometry.rotations import angle_between
from testbed.physics import percentile_summary


class SatDepth:
    """The `depth` call compare_figures needs from a predictor, by the separating-axis test
    (testbed/geometry/boxes.py): (n,) penetration [m] of B into A, negative = separated."""

    def depth(self, p_AB, R_AB, *, size_A, size_B):
        p, R = np.asarray(p_AB, float).reshape(-1, 3), np.asarray(R_AB, float).reshape(-1, 3, 3)
        sizes = np.hstack([np.asarray(size_A, float).reshape(-1, 3), np.asarray(size_B, float).reshape(-1, 3)])
        out = np.zeros(len(p))
        unique, inverse = np.unique(sizes, axis=0, return_inverse=True)
        for u, row in enumerate(unique):
            rows = np.flatnonzero(inverse.ravel() == u)
            out[rows] = -box_box_signed_distance(p[rows], R[rows], 0.5 * row[:3], 0.5 * row[3:])
        return out


def centre_of_pressure_in_plane(rows: dict, index) -> np.ndarray:
    """(n, 3) [m] where the line of action of Drake's contact wrench crosses the contact plane
    (through p_W_centroid, normal n_W). contact_log's p_W_cop is the point of that line
    nearest the centroid, which leaves the plane when friction tilts the force: a 2.2 t box
    held by a 24 m/s side wind (f_t/f_n = 0.31) has them 0.12 m apart. MuJoCo's
    force-weighted centroid lies in the plane, so the plane crossing is what it is judged
    against. Rows whose force has no normal part keep p_W_cop."""
    cop, c = rows["p_W_cop"][index], rows["p_W_centroid"][index]
    n, f = rows["n_W"][index], rows["f_W"][index]
    fn = np.einsum("ni,ni->n", f, n)
    ok = fn > 1e-9 * np.maximum(np.linalg.norm(f, axis=1), 1e-300)
    s = np.where(ok, np.einsum("ni,ni->n", c - cop, n) / np.where(ok, fn, 1.0), 0.0)
    return cop + s[:, None] * f


def contact_figures(drake_contacts: dict, other_contacts: dict) -> dict:
    """Point [m] and normal [deg] errors of a candidate's contact rows (`other_contacts`)
    against Drake's centre of pressure (in the contact plane, see
    centre_of_pressure_in_plane) and normal, over the (step, a, b) rows both have; the rows
    Drake has and the candidate lacks (contact_rows_missing), and the candidate's rows at
    Drake's logged steps that Drake lacks (contact_rows_extra)."""
    def keyed(t):
        return {(int(s), int(a), int(b)): i for i, (s, a, b) in enumerate(zip(t["step"], t["a"], t["b"]))}

    drake, mj = keyed(drake_contacts), keyed(other_contacts)
    common = [k for k in drake if k in mj]
    steps = {k[0] for k in drake}
    extra = sum(1 for k in mj if k[0] in steps and k not in drake)
    out = {"contact_rows_compared": len(common), "contact_rows_missing": len(drake) - len(common),
           "contact_rows_extra": extra}
    if not common:
        return out
    i_d = np.array([drake[k] for k in common])
    i_m = np.array([mj[k] for k in common])
    point_err = np.linalg.norm(other_contacts["p_W_cop"][i_m] - centre_of_pressure_in_plane(drake_contacts, i_d), axis=1)
    angle = np.degrees(angle_between(other_contacts["n_W"][i_m], drake_contacts["n_W"][i_d]))
    last = np.array([k[0] for k in common]) == max(k[0] for k in common)  # the last compared step
    for name, values in (("contact_point_error", point_err), ("contact_normal_error", angle)):
        unit = "m" if name == "contact_point_error" else "deg"
        for stat, value in percentile_summary(values, (50, 95)).items():
            out[f"{name}_{stat}_{unit}"] = value
        out[f"{name}_final_max_{unit}"] = float(values[last].max())
    return out


def max_penetration(contacts: dict) -> float:
    """[m] the deepest penetration of a run's contact rows (0 without contact)."""
    return float(max(0.0, -contacts["phi"].min())) if len(contacts["phi"]) else 0.0
