"""The query study's run: pose sets x methods, measured, aggregated, written.

Outputs in out_dir: query.json (metrics, schema SCHEMA), query.md (tables, the paper's
Tables 3 and 4 next to today's figures), query_pareto.png (time per query, log scale,
against point and normal error). Keys of query.json: see testbed/studies/query/__init__.py.
"""

from __future__ import annotations

import json
import os
import platform
import sys
import time
from pathlib import Path

from testbed.errors import OptionalDependencyError
from testbed.records import write_atomic
from testbed.studies.query import paper, render
from testbed.studies.query.aggregate import by_tilt, pareto_front, soup_tables, summary
from testbed.studies.query.measure import measure_set, one_blas_thread, throughput
from testbed.studies.query.methods import MethodOptions, Scenes, build_methods
from testbed.studies.query.methods.base import PINS
from testbed.studies.query.poses import NEAR_DEPTH, STUDY_SEED_OFFSET, TILT_RANGE, TYPES, make_pose_sets

SCHEMA = "testbed.study.query/1"
SOUP_N_FULL = (8, 10, 12, 14, 16, 18, 20, 22)
SOUP_N_QUICK = (8, 14, 22)


def _environment() -> dict:
    from importlib import metadata

    versions = {}
    for pkg in ("drake", "numpy", "python-fcl", "mujoco", "matplotlib", "threadpoolctl"):
        try:
            versions[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            versions[pkg] = None
    return {"python": sys.version.split()[0], "platform": platform.platform(), "machine": platform.machine(),
            "cpu_count": os.cpu_count(), "packages": versions, "pins": PINS}


def run_query_study(out_dir, *, n_poses: int | None = None, seed: int = 0, quick: bool = False,
                    progress: bool = True, repeats: int | None = None, soup_ns=None, predictor=None,
                    paper_weights=None, extra_predictors=()) -> dict:
    """Runs the query study and writes query.json, query.md, query_pareto.png to out_dir.

    n_poses: proposals per pose set (default 200, quick 12); seed: sampling seed;
    quick: fewer poses, repeats (3) and soup resolutions (N = 8, 14, 22), well under a
    minute on 2 cores; repeats: timed calls per pose (default 7); soup_ns: N values to
    run; predictor, paper_weights: weights files of the improved predictor and the
    paper MLP (None: the shipped ones; missing files make those methods unavailable).
    Returns the metrics dict (JSON-serialisable; keys documented in query.md and the
    module docstring). Raises OptionalDependencyError when python-fcl, mujoco or
    matplotlib is missing (install with pip install -e '.[study]').
    """
    for pkg, mod in (("python-fcl", "fcl"), ("mujoco", "mujoco"), ("matplotlib", "matplotlib")):
        try:
            __import__(mod)
        except ImportError:
            raise OptionalDependencyError(pkg, "the query study", "study") from None
    t_start = time.perf_counter()
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    n_poses = n_poses if n_poses is not None else (24 if quick else 200)
    repeats = repeats if repeats is not None else (3 if quick else 7)
    soup_ns = tuple(soup_ns) if soup_ns is not None else (SOUP_N_QUICK if quick else SOUP_N_FULL)
    sets = make_pose_sets(n_poses, seed, progress=progress)
    t_labels = time.perf_counter() - t_start
    scenes = Scenes()
    options = MethodOptions(soup_ns=soup_ns, predictor=predictor, paper_weights=paper_weights,
                            extra_predictors=tuple(extra_predictors))
    results, method_info = {}, {}
    with one_blas_thread() as blas_threads:
        for name, poses in sets.items():
            methods = build_methods(poses, scenes, options)
            results[name] = measure_set(poses, methods, repeats, progress=progress)
            for m in methods:
                method_info.setdefault(m.name, m)
    metrics = {
        "schema": SCHEMA,
        "config": {"n_poses": n_poses, "seed": seed, "quick": quick, "repeats": repeats, "soup_N": list(soup_ns),
                   "types": list(TYPES), "tilt_range_rad": list(TILT_RANGE), "near_parallel_depth_m": list(NEAR_DEPTH),
                   "sampling_seed": 10 * seed + STUDY_SEED_OFFSET},
        "environment": _environment(),
        "reference": "Drake hydroelastic compliant-compliant (E = 1e9 Pa, as shipped): centre of pressure and pressure-weighted "
                     "normal (learned_contact.data.labels)",
        "pose_sets": {k: {"n": len(v), "n_dropped": v.n_dropped} for k, v in sets.items()},
        "methods": {},
    }
    names = list(method_info)
    for name in names:
        m = method_info[name]
        entry = {"label": m.label, "family": m.family, "available": m.available, "reason": m.reason, **m.extra}
        if m.available:
            per = [(results[s][name], sets[s]) for s in sets if name in results[s] and len(sets[s])]
            entry["all"] = summary([r for r, _ in per], [p for _, p in per])
            entry["by_set"] = {s: summary([results[s][name]], [sets[s]]) for s in sets
                               if name in results[s] and len(sets[s])}
        metrics["methods"][name] = entry
    with one_blas_thread():
        throughput(metrics["methods"], sets, scenes, options, repeats)
    metrics["environment"]["blas_threads"] = blas_threads
    metrics["polygon_soup"] = soup_tables(results, sets, soup_ns)
    metrics["near_parallel_by_tilt"] = by_tilt(results, sets)
    avail = {k: v for k, v in metrics["methods"].items() if v["available"]}
    metrics["pareto"] = {
        "x": "all.time_us.mean", "y": ["all.point_error_m.mean", "all.normal_error_deg.mean"],
        "point_front": pareto_front({k: (v["all"]["time_us"]["mean"], v["all"]["point_error_m"]["mean"])
                                     for k, v in avail.items() if k != "drake_hydro_cc"}),
        "normal_front": pareto_front({k: (v["all"]["time_us"]["mean"], v["all"]["normal_error_deg"]["mean"])
                                      for k, v in avail.items() if k != "drake_hydro_cc"}),
    }
    metrics["paper"] = paper.as_metrics()
    metrics["wall_time_s"] = {"labels": t_labels, "total": time.perf_counter() - t_start}
    metrics["files"] = {"json": "query.json", "markdown": "query.md", "chart": "query_pareto.png"}
    chart = render.chart_png(metrics)
    metrics["markdown"] = render.markdown(metrics, chart)
    write_atomic(out_dir / render.CHART_FILE, chart)
    write_atomic(out_dir / "query.md", metrics["markdown"])
    write_atomic(out_dir / "query.json", json.dumps(metrics, indent=2, allow_nan=False) + "\n")
    return metrics
