"""Statistics of the query study: errors against the reference, per-method summaries,
the Pareto fronts, the paper's Tables 3 and 4 on today's tools, errors by tilt."""

from __future__ import annotations

import math

import numpy as np

from testbed.contact.surfaces import angle_between
from testbed.physics import percentile_summary
from testbed.studies.query.poses import TILT_RANGE


def stats(values, scale: float = 1.0) -> dict:
    """n, n_missing (NaN), mean, median, p99, max of values * scale (finite values only)."""
    v = np.asarray(values, dtype=float) * scale
    ok = np.isfinite(v)
    if not ok.any():
        return {"n": 0, "n_missing": int(len(v)), "mean": None, "median": None, "p99": None, "max": None}
    f = v[ok]
    return {"n": int(ok.sum()), "n_missing": int((~ok).sum()), "mean": float(f.mean()),
            **percentile_summary(f, percentiles=(50, 99))}


def errors(res: dict, poses):
    """(point error (n,) [m], normal error (n,) [deg]) of one method's answers on a set."""
    e_point = np.linalg.norm(res["point"] - poses.cop, axis=1)  # (n,) [m]
    e_normal = np.degrees(angle_between(res["normal"], poses.normal))  # (n,) [deg]
    return e_point, e_normal


def summary(res_list, poses_list) -> dict:
    """Figures of one method over one or more sets (concatenated)."""
    q = np.concatenate([r["query_ns"] for r in res_list])
    e = [errors(r, p) for r, p in zip(res_list, poses_list)]
    out = {"time_us": stats(q, 1e-3), "point_error_m": stats(np.concatenate([a for a, _ in e])),
           "normal_error_deg": stats(np.concatenate([b for _, b in e]))}
    if res_list[0]["kernel_ns"] is not None:
        out["kernel_time_us"] = stats(np.concatenate([r["kernel_ns"] for r in res_list]), 1e-3)
    if "batch_ns" in res_list[0]:
        # per-pair time of each repeat of each set's batch call
        b = np.concatenate([r["batch_ns"] for r in res_list]) * 1e-3
        out["time_us"].update({"p99": float(np.percentile(b, 99)), "max": float(b.max())})
    counts = np.concatenate([r["count"] for r in res_list])
    if np.any(counts >= 0):
        out["count"] = {"mean": float(counts[counts >= 0].mean()), "max": int(counts.max())}
    return out


def pareto_front(points: dict) -> list[str]:
    """Names not dominated in (time, error): {name: (time, error)} -> sorted by time."""
    items = sorted((t, e, k) for k, (t, e) in points.items() if t is not None and e is not None)
    front, best = [], math.inf
    for _t, e, k in items:
        if e < best:
            front.append(k)
            best = e
    return front

def soup_tables(results, sets, soup_ns) -> dict:
    """Per N: the paper's Table 3 (average time) and Table 4 (the pose with the most
    triangle tests, its time) on today's tools, over all pose sets."""
    out = {}
    for n in soup_ns:
        name = f"soup_N{n}"
        per = [(s, results[s][name]) for s in sets if name in results[s] and len(sets[s])]
        if not per:
            continue
        q = np.concatenate([r["query_ns"] for _, r in per]) * 1e-6  # [ms]
        k = np.concatenate([r["kernel_ns"] for _, r in per]) * 1e-6
        pairs = np.concatenate([r["count"] for _, r in per])
        cand = np.concatenate([r.get("candidates", np.zeros(len(r["count"]), int)) for _, r in per])
        where = [(s, i) for s, r in per for i in range(len(r["count"]))]
        i_pairs, i_cand = int(np.argmax(pairs)), int(np.argmax(cand))
        typical = np.concatenate([r["kernel_ns"] for s, r in per if s != "near_parallel"]) * 1e-6
        out[str(n)] = {
            "triangles_per_box": 12 * n * n, "triangles_per_face": 2 * n * n,
            "avg_kernel_ms": float(np.nanmean(k)), "avg_kernel_ms_typical": float(np.nanmean(typical)) if len(typical) else None,
            "avg_query_ms": float(np.nanmean(q)),
            "max_colliding_pairs": int(pairs[i_pairs]), "max_pairs_pose": {"set": where[i_pairs][0], "index": where[i_pairs][1]},
            "kernel_ms_at_max_pairs": float(k[i_pairs]), "query_ms_at_max_pairs": float(q[i_pairs]),
            "max_candidate_pairs": int(cand[i_cand]), "kernel_ms_at_max_candidates": float(k[i_cand]),
            "worst_kernel_ms": float(np.nanmax(k)), "worst_query_ms": float(np.nanmax(q)),
            "p99_kernel_ms": float(np.nanpercentile(k, 99)),
        }
    return out


def by_tilt(results, sets) -> dict:
    """Near-parallel set in tilt decades: per method mean point error [m] and mean
    query time [us] (the worst case of the paper grows as the tilt shrinks)."""
    poses = sets.get("near_parallel")
    if poses is None or len(poses) == 0:
        return {}
    edges = np.arange(math.floor(math.log10(TILT_RANGE[0])), math.ceil(math.log10(TILT_RANGE[1])) + 1)
    decade = np.clip(np.floor(np.log10(poses.tilt)).astype(int), edges[0], edges[-2])
    out = {"decades": [f"1e{d}..1e{d + 1}" for d in edges[:-1]], "methods": {}}
    for name, res in results["near_parallel"].items():
        e_point, _ = errors(res, poses)
        rows = []
        for d in edges[:-1]:
            m = decade == d
            rows.append({"n": int(m.sum()),
                         "point_error_m": float(np.nanmean(e_point[m])) if m.any() and np.isfinite(e_point[m]).any() else None,
                         "time_us": float(np.nanmean(res["query_ns"][m]) * 1e-3) if m.any() else None,
                         "count_max": int(res["count"][m].max()) if m.any() else None})
        out["methods"][name] = rows
    return out
