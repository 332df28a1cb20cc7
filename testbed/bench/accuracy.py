"""The bench's accuracy section: every predictor on the same held-out pose sets.

Sets (labelled by Drake's static hydroelastic contact, learned_contact.data.labels; the
seeds the accuracy gates use, so the figures are the gates' own; a model declaring fewer
container sizes gets the same sets drawn over the ordered pairs of its own types alone, as many
proposals: learned_contact.data.sampling.types_of_sizes):
- "stacking", "general", "outside": learned_contact.evaluation.gates.held_out (the training
  distributions re-drawn from unused seeds, and stacking poses beyond the training
  ranges);
- "resting": where shipped stacks sit at 1e9 Pa (learned_contact.data.sampling's "resting"
  distribution: overlap log-uniform from 5 um to 0.5 mm, roll and pitch within 0.05 deg,
  yaw within 2 deg, offsets up to 0.4 m), the gates' own resting set;
- "resting_wider": where landings and overhangs leave a box resting (yaw within
  6 deg, offsets up to 3 m along A's x and 0.6 m along y, half of the poses exactly level),
  the gates' own wider resting set, and "resting_wider_level", its exactly level poses.

Per predictor and set: point error [m] and normal error [deg], median / p95 / p99, and
the ratio of each to the geometric prior's on the same poses (learned_contact.gates.
GeometricPrior; < 1: the model improves on geometry alone). The accuracy gates of
learned_contact.evaluation.gates are judged for every predictor with the same thresholds.
"""

from __future__ import annotations

import numpy as np

from learned_contact.data.sampling import DEFAULT_TYPES
from learned_contact.evaluation.gates import GeometricPrior, answer_figures, held_out, verdicts
from learned_contact.evaluation.metrics import point_normal_errors
from learned_contact.interface import SIZE_TOLERANCE

SETS = ("stacking", "general", "outside", "resting", "resting_wider", "resting_wider_level")
STATS = (("median", 50), ("p95", 95), ("p99", 99))


def pose_sets(seed: int, n: int, *, workers: int = 2, types=DEFAULT_TYPES) -> dict:
    """{set name: learned_contact Dataset}: the gates' held-out sets (SETS: resting and resting_wider
    included), n proposals each, drawn over the ordered pairs of container `types` (the default: the
    gates' own poses; a model's declared types, BenchModel.types: as many poses, all of its sizes)."""
    return held_out(seed, n, workers=workers, types=tuple(types))


def _stats(e_point, e_normal) -> dict:
    """{"point_<stat>_m", "normal_<stat>_deg"} of point errors [m] and normal errors [deg] (STATS)."""
    out = {}
    for name, q in STATS:
        out[f"point_{name}_m"] = float(np.percentile(e_point, q))
        out[f"normal_{name}_deg"] = float(np.percentile(e_normal, q))
    return out


def supported_rows(predictor, ds) -> np.ndarray:
    """(n,) bool: poses of Dataset `ds` whose two sizes are both among the predictor's
    supported_sizes (within learned_contact.interface.SIZE_TOLERANCE per axis)."""
    supported = np.asarray(predictor.supported_sizes, dtype=float).reshape(-1, 3)

    def ok(size):
        return np.abs(np.asarray(size, dtype=float)[:, None, :] - supported[None]).max(axis=2).min(axis=1) <= SIZE_TOLERANCE

    return ok(ds.size_A) & ok(ds.size_B)


def covered(predictor, data: dict) -> tuple[dict, dict]:
    """(the sets cut to the poses the predictor declares it answers, {set: (kept, of)}): a
    model for one container type is judged on its own type's poses; a set it does not
    cover at all is left out (its gates with it: learned_contact.evaluation.gates.verdicts)."""
    kept, counts = {}, {}
    for name, ds in data.items():
        rows = supported_rows(predictor, ds)
        counts[name] = (int(rows.sum()), len(ds))
        if rows.all():
            kept[name] = ds
        elif rows.any():
            kept[name] = ds.subset(np.flatnonzero(rows))
    return kept, counts


def accuracy(model, data: dict, seed: int) -> dict:
    """{"sets": {set: figures + "*_vs_prior" ratios + "n"}, "gates": learned_contact.evaluation.gates
    verdicts, "gates_passed", "gates_total", "coverage": {set: [kept, of]}} for one BenchModel (or
    predictor) on the poses of `data` (pose_sets: drawn over its declared types, so all of them)
    it declares it answers (`covered`). The model is asked once per set: its figures and the gates
    read the same answers."""
    predictor = getattr(model, "predictor", model)
    data, counts = covered(predictor, data)
    answers = {name: predictor.predict(ds.p_AB, ds.R_AB, size_A=ds.size_A, size_B=ds.size_B) for name, ds in data.items()}
    gates = verdicts(answer_figures(answers, data), max((len(ds) for ds in data.values()), default=0), seed) if data else []
    prior = GeometricPrior()
    sets = {}
    for name, ds in data.items():
        point, normal = answers[name]
        errors = point_normal_errors(point, normal, ds)
        prior_errors = point_normal_errors(*prior.predict(ds.p_AB, ds.R_AB, size_A=ds.size_A, size_B=ds.size_B), ds)
        mine, base = _stats(*errors), _stats(*prior_errors)
        figures = {"n": len(ds), **mine}
        for key, value in mine.items():
            figures[f"{key}_vs_prior"] = value / base[key] if base[key] > 0 else float("inf")
            figures[f"prior_{key}"] = base[key]
        # the second reference (Drake's one-point rule) and the truth's own gap to it, on the same poses
        figures["point_median_m_vs_one_point"] = float(np.median(np.linalg.norm(point - ds.cop_one_point, axis=1)))
        figures["truth_gap_median_m"] = float(np.median(np.linalg.norm(ds.cop - ds.cop_one_point, axis=1)))
        sets[name] = figures
    return {"sets": sets, "gates": gates, "gates_passed": sum(g["passed"] for g in gates), "gates_total": len(gates),
            "coverage": {k: list(v) for k, v in counts.items()}}
