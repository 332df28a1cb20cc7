"""Error measures: the paper's ME/MAE/RMSE tables and contact point/normal statistics."""

from __future__ import annotations

import numpy as np

from learned_contact.model.encodings import angle_error, octant_signs, paper_outputs
from learned_contact.model.prior import CONTACT_TYPES
from testbed.geometry.rotations import angle_between

PAPER_OUTPUT_NAMES = ("az_point", "el_point", "az_force", "el_force")
# The paper's published figures (averaged over its 4 outputs), for side-by-side reports.
PAPER_TABLE_1 = {"train": {"ME": 0.0332, "MAE": 0.4161, "RMSE": 0.6947},
                 "validation": {"ME": 0.0259, "MAE": 0.4383, "RMSE": 0.7363},
                 "external": {"ME": -0.0005, "MAE": 0.5624, "RMSE": 0.8667}}
PAPER_TABLE_2 = {"train": {"ME": -0.0008, "MAE": 0.2765, "RMSE": 0.5410},
                 "validation": {"ME": 0.0031, "MAE": 0.2883, "RMSE": 0.5748},
                 "external": {"ME": 0.0467, "MAE": 0.4523, "RMSE": 0.7302}}


def paper_table(pred4, true4) -> dict:
    """ME, MAE, RMSE [rad] per paper output and averaged ("mean"), from (n, 4) angles.
    Azimuth errors are wrapped into [-pi, pi)."""
    err = angle_error(pred4, true4)
    out = {}
    for i, name in enumerate(PAPER_OUTPUT_NAMES):
        e = err[:, i]
        out[name] = {"ME": float(e.mean()), "MAE": float(np.abs(e).mean()), "RMSE": float(np.sqrt((e**2).mean()))}
    out["mean"] = {k: float(np.mean([out[n][k] for n in PAPER_OUTPUT_NAMES])) for k in ("ME", "MAE", "RMSE")}
    return out


def stats(values) -> dict:
    """median, p95, p99, max of a 1-D array (NaN when empty)."""
    v = np.asarray(values, dtype=float)
    if len(v) == 0:
        return {"n": 0, "median": float("nan"), "p95": float("nan"), "p99": float("nan"), "max": float("nan")}
    q = np.percentile(v, [50, 95, 99])
    return {"n": int(len(v)), "median": float(q[0]), "p95": float(q[1]), "p99": float(q[2]), "max": float(v.max())}


def point_normal_errors(point, normal, ds):
    """(point error (n,) [m], normal error (n,) [deg]) against a Dataset's labels."""
    e_point = np.linalg.norm(point - ds.cop, axis=1)
    return e_point, np.degrees(angle_between(normal, ds.normal))  # atan2: well conditioned near 0 deg


def evaluate(point, normal, ds) -> dict:
    """All figures of one model on one Dataset: paper table, point error [m] and [% of
    A's length], normal error [deg], overall and per contact type."""
    S = octant_signs(ds.p_AB)
    e_point, e_normal = point_normal_errors(point, normal, ds)
    pct = 100.0 * e_point / ds.size_A[:, 0]
    out = {"n": len(ds), "paper_table": paper_table(paper_outputs(point, normal, S), paper_outputs(ds.cop, ds.normal, S)),
           "point_m": stats(e_point), "point_pct_length": stats(pct), "normal_deg": stats(e_normal), "by_type": {}}
    for t, name in enumerate(CONTACT_TYPES):
        m = ds.tag == t
        out["by_type"][name] = {"point_m": stats(e_point[m]), "point_pct_length": stats(pct[m]),
                                "normal_deg": stats(e_normal[m])}
    return out
