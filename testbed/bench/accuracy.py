"""The bench's accuracy section: every predictor on the same held-out pose sets.

Sets (labelled by Drake's static hydroelastic contact, learned_contact.labels; the
seeds the accuracy gates use, so the figures are the gates' own):
- "stacking", "general", "outside": learned_contact.gates.held_out (the training
  distributions re-drawn from unused seeds, and stacking poses beyond the training
  ranges);
- "resting": where shipped stacks sit at 1e9 Pa (learned_contact.sampling's "resting"
  distribution: overlap log-uniform from 5 um to 0.5 mm, roll and pitch within 0.05 deg,
  yaw within 2 deg, offsets up to 0.4 m), the gates' own resting set.

Per predictor and set: point error [m] and normal error [deg], median / p95 / p99, and
the ratio of each to the geometric prior's on the same poses (learned_contact.gates.
GeometricPrior; < 1: the model improves on geometry alone). The accuracy gates of
learned_contact.gates are judged for every predictor with the same thresholds.
"""

from __future__ import annotations

import numpy as np

from learned_contact.gates import GeometricPrior, gate_figures, held_out, verdicts
from learned_contact.metrics import point_normal_errors

SETS = ("stacking", "general", "outside", "resting")
STATS = (("median", 50), ("p95", 95), ("p99", 99))


def pose_sets(seed: int, n: int, *, workers: int = 2) -> dict:
    """{set name: learned_contact Dataset}: the gates' held-out sets (resting included)."""
    return held_out(seed, n, workers=workers)


def _stats(point, normal, ds) -> dict:
    e_point, e_normal = point_normal_errors(point, normal, ds)
    out = {}
    for name, q in STATS:
        out[f"point_{name}_m"] = float(np.percentile(e_point, q))
        out[f"normal_{name}_deg"] = float(np.percentile(e_normal, q))
    return out


def accuracy(predictor, data: dict, seed: int) -> dict:
    """{"sets": {set: figures + "*_vs_prior" ratios + "n"}, "gates": learned_contact.gates
    verdicts, "gates_passed", "gates_total"} for one predictor on `data` (pose_sets)."""
    prior = GeometricPrior()
    sets = {}
    for name, ds in data.items():
        mine = _stats(*predictor.predict(ds.p_AB, ds.R_AB, size_A=ds.size_A, size_B=ds.size_B), ds)
        base = _stats(*prior.predict(ds.p_AB, ds.R_AB, size_A=ds.size_A, size_B=ds.size_B), ds)
        figures = {"n": len(ds), **mine}
        for key, value in mine.items():
            figures[f"{key}_vs_prior"] = value / base[key] if base[key] > 0 else float("inf")
            figures[f"prior_{key}"] = base[key]
        sets[name] = figures
    gates = verdicts(gate_figures(predictor, data), len(data["stacking"]), seed)
    return {"sets": sets, "gates": gates, "gates_passed": sum(g["passed"] for g in gates), "gates_total": len(gates)}
