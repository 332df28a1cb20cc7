"""Issue 3's accuracy gates, evaluated on held-out poses made on the spot.

`evaluate_gates(seed)` labels N_HELD_OUT stacking and general poses with sampling seeds
10 * seed + 5 and 10 * seed + 6 (training uses + 1 and + 2), runs the predictor and
returns {"gates": [{name, passed, value, threshold, unit, description}], "figures": ...}.
The pytest gates (tests/test_learned_gates.py) and `testbed validate` both use it.
"""

from __future__ import annotations

import numpy as np

from learned_contact.encodings import octant_signs, paper_outputs
from learned_contact.metrics import paper_table, point_normal_errors

N_HELD_OUT = 400
THRESHOLDS = {
    "stacking point error median": (0.03, "m"),
    "stacking point error p95": (0.15, "m"),
    "stacking normal error p95": (1.0, "deg"),
    "general normal error median": (3.0, "deg"),
    "general MAE on the paper's 4 outputs": (0.15, "rad"),
}


def held_out(seed: int, n: int = N_HELD_OUT, *, workers: int = 2, progress: bool = False) -> dict:
    """{"stacking": Dataset, "general": Dataset} of held-out poses (not cached)."""
    from learned_contact.labels import make_dataset

    return {d: make_dataset(d, n, 10 * seed + k, workers=workers, progress=progress, use_cache=False)
            for d, k in (("stacking", 5), ("general", 6))}


def gate_figures(predictor, data: dict) -> dict:
    """The measured figure of every gate in THRESHOLDS for `predictor` on `data`."""
    out = {}
    for dist, ds in data.items():
        point, normal = predictor.predict(ds.p_AB, ds.R_AB, size_A=ds.size_A, size_B=ds.size_B)
        e_point, e_normal = point_normal_errors(point, normal, ds)
        S = octant_signs(ds.p_AB)
        mae = paper_table(paper_outputs(point, normal, S), paper_outputs(ds.cop, ds.normal, S))["mean"]["MAE"]
        out[f"{dist} point error median"] = float(np.median(e_point))
        out[f"{dist} point error p95"] = float(np.percentile(e_point, 95))
        out[f"{dist} normal error median"] = float(np.median(e_normal))
        out[f"{dist} normal error p95"] = float(np.percentile(e_normal, 95))
        out[f"{dist} MAE on the paper's 4 outputs"] = float(mae)
    return out


def evaluate_gates(seed: int = 0, *, predictor_path=None, n: int = N_HELD_OUT) -> dict:
    """Gates of the predictor at `predictor_path` (default: shipped) on fresh held-out poses."""
    from learned_contact.loading import load_predictor

    figures = gate_figures(load_predictor(predictor_path), held_out(seed, n))
    gates = [{"name": name, "passed": bool(figures[name] <= limit), "value": figures[name], "threshold": limit,
              "unit": unit, "description": f"{name} on {n} held-out poses (seed {seed}), must be <= {limit} {unit}"}
             for name, (limit, unit) in THRESHOLDS.items()]
    return {"gates": gates, "figures": figures, "n": n, "seed": seed}
