"""The bench's force section: the closed loop's contact force against the truth's on every held-out
pose set, as the accuracy section judges the point and normal.

A predictor answers a point and a normal, and the testbed's force law supplies the force, so the
force is judged once per set for every such predictor, for the law the learned loop runs
(LearnedDynamicsConfig.grid: 0, the exact field contact), with the former Winkler foundation (grid 4)
beside it on the same poses. The truth: Drake's static hydroelastic force at each
pose (the labels' `force`, exact for Drake's piecewise-linear field; linear in the modulus, so scaled
to the law's), and for the stiffness the central difference of the truth's force along its direction
(+-1 um), which the exact answer reproduces to 1e-9 (tests/learned/test_static_contact.py). A user's
model that answers its own force (the contract's optional force_n, stiffness, area) is driven by it in
the loop and judged on the same poses (own_force_figures).

Per set: the force magnitude's relative error (median, p95), its direction against the truth's
pressure-weighted normal (p95 [deg]), the poses whose true force exceeds 1 % of a 10 t weight that get
0 N, and the stiffness's relative error (median, p95) on the first STIFFNESS_POSES poses that carry
over 1 kN.
"""

from __future__ import annotations

import numpy as np

from learned_contact.data.labels import LABEL_MODULUS
from learned_contact.predictors.external import FORCE_MODULUS
from testbed.bench import step_cost
from testbed.effects.learned_dynamics.force_law import KAPPA_MODULUS
from testbed.effects.learned_dynamics.static import static_answer
from testbed.effects.learned_dynamics.step import elastic
from testbed.geometry.rotations import angle_between
from testbed.physics import GRAVITY

ZERO_FORCE_N = 0.01 * 1e4 * GRAVITY  # [N] 1 % of a 10 t weight: a true force above it answered with 0 N
STIFFNESS_POSES = 200
DIFFERENCE_M = 1e-6  # [m] the central difference's step along the truth's force


def _figures(force, stiffness, truth, truth_k, rows) -> dict:
    F, F_true = np.linalg.norm(force, axis=1), np.linalg.norm(truth, axis=1)
    ok = F_true > 1e-3  # below 1 mN both are round-off-sized
    rel = np.abs(F[ok] / F_true[ok] - 1)
    with np.errstate(invalid="ignore"):
        angle = np.degrees(angle_between(force[ok], truth[ok]))
    k_rel = np.abs(stiffness[rows] / truth_k - 1) if len(rows) else np.array([np.nan])
    return {"force_rel_median": float(np.median(rel)), "force_rel_p95": float(np.percentile(rel, 95)),
            "direction_p95_deg": float(np.nanpercentile(angle, 95)) if np.isfinite(angle).any() else float("nan"),
            "zero_answers": int(np.sum((F_true > ZERO_FORCE_N) & (F == 0))),
            "stiffness_rel_median": float(np.median(k_rel)), "stiffness_rel_p95": float(np.percentile(k_rel, 95))}


def step_cost_rows(budget_s: float = 0.05) -> dict:
    """{state: {"ratio", "exact_us", "foundation_us", "verdict"}}: the learned step's cost with the exact
    force over the foundation's, side by side (testbed/bench/step_cost.py); {} without the native core."""
    try:
        measured = step_cost.ratios(budget_s)
    except ImportError:
        return {}
    return {name: {"ratio": r, "exact_us": a, "foundation_us": b, "verdict": step_cost.verdict(name, r)}
            for name, (r, a, b) in measured.items()}


def force_section(data: dict, modulus: float = KAPPA_MODULUS) -> dict:
    """{"law", "modulus_Pa", "sets": {set: {"n", "exact": figures, "foundation": figures}}} (module
    docstring) for the bench's pose sets `data` ({name: learned_contact Dataset with `force`})."""
    sets = {}
    for name, ds in data.items():
        if ds.force is None or not len(ds):
            continue
        truth = ds.force * (modulus / LABEL_MODULUS)
        exact = static_answer(ds.p_AB, ds.R_AB, ds.size_A, ds.size_B, modulus=modulus)
        hA, hB = 0.5 * np.asarray(ds.size_A, dtype=float), 0.5 * np.asarray(ds.size_B, dtype=float)
        kappa = [modulus / (a.min() + b.min()) for a, b in zip(hA, hB)]
        old = np.array([elastic(p, R, a, b, k, 4) for p, R, a, b, k in zip(ds.p_AB, ds.R_AB, hA, hB, kappa)])
        n_true = truth / np.maximum(np.linalg.norm(truth, axis=1, keepdims=True), 1e-300)
        old_force = old[:, :1] * n_true  # the foundation's magnitude along the truth's normal (its law's direction)
        rows = np.flatnonzero(np.linalg.norm(truth, axis=1) > 1e3)[:STIFFNESS_POSES]
        d = DIFFERENCE_M * n_true[rows]
        deeper = static_answer(ds.p_AB[rows] - d, ds.R_AB[rows], ds.size_A[rows], ds.size_B[rows], modulus=modulus).force
        shallower = static_answer(ds.p_AB[rows] + d, ds.R_AB[rows], ds.size_A[rows], ds.size_B[rows], modulus=modulus).force
        truth_k = np.einsum("ni,ni->n", deeper - shallower, n_true[rows]) / (2 * DIFFERENCE_M)
        sets[name] = {"n": len(ds), "exact": _figures(exact.force, exact.stiffness, truth, truth_k, rows),
                      "foundation": _figures(old_force, old[:, 2], truth, truth_k, rows)}
    return {"law": "the exact field contact (grid 0), every predictor alike", "modulus_Pa": modulus, "sets": sets}


def own_force_figures(model, data: dict, modulus: float = KAPPA_MODULUS) -> dict:
    """{set: figures} of a model's own force (ExternalPredictor.contact_force: F along its normal,
    its stiffness, at FORCE_MODULUS, scaled to `modulus`) against the truth on the pose sets `data`,
    as force_section judges the law's; the stiffness on the same poses as there."""
    out = {}
    for name, ds in data.items():
        if ds.force is None or not len(ds):
            continue
        truth = ds.force * (modulus / LABEL_MODULUS)
        rows = model.contact_force(ds.p_AB, ds.R_AB, size_A=ds.size_A, size_B=ds.size_B) * np.array(
            [modulus / FORCE_MODULUS, modulus / FORCE_MODULUS, 1.0])
        _, normal = model.predict(ds.p_AB, ds.R_AB, size_A=ds.size_A, size_B=ds.size_B)
        n_true = truth / np.maximum(np.linalg.norm(truth, axis=1, keepdims=True), 1e-300)
        k_rows = np.flatnonzero(np.linalg.norm(truth, axis=1) > 1e3)[:STIFFNESS_POSES]
        d = DIFFERENCE_M * n_true[k_rows]
        deeper = static_answer(ds.p_AB[k_rows] - d, ds.R_AB[k_rows], ds.size_A[k_rows], ds.size_B[k_rows],
                               modulus=modulus).force
        shallower = static_answer(ds.p_AB[k_rows] + d, ds.R_AB[k_rows], ds.size_A[k_rows], ds.size_B[k_rows],
                                  modulus=modulus).force
        truth_k = np.einsum("ni,ni->n", deeper - shallower, n_true[k_rows]) / (2 * DIFFERENCE_M)
        out[name] = _figures(rows[:, :1] * np.asarray(normal, dtype=float), rows[:, 1], truth, truth_k, k_rows)
    return out
