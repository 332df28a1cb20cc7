"""The closed loop's shadow truth: Drake's static hydroelastic answer at the learned pairs' poses.

With `contact_log` and `learned_dynamics.shadow_truth`, the `closed_loop` table carries,
next to the learned answer of every active pair, Drake's static hydroelastic answer for
the same relative pose (a testbed.pair_plant.ContainerPair plant per size pair, at the
containers' modulus). Computing it is ~0.25 ms per pair (ComputeContactSurfaces and the
per-face reads of testbed.contact_geometry.surface_face_arrays): on every step it cost a
9-high stack ~7x the bare closed loop. So it is SAMPLED: computed on the steps whose
number is a multiple of `truth_every_steps` (step = round(t / h); step 0 included) and
absent on the others. Every row still carries the columns:

  has_truth (k,) bool      True: this row's step was sampled and the truth computed on its
                           own state (never held from an earlier step)
  p_W_truth, n_W_truth (k, 3) [m], [-]  Drake's pressure-weighted centre of pressure and
                           unit normal (A -> B) in W; NaN where has_truth is False or Drake
                           finds no contact surface at that pose
  fn_truth (k,) [N]        Drake's static normal force; NaN where has_truth is False, 0 where
                           sampled and Drake finds no surface
  point_error (k,) [m], normal_error_deg (k,) [deg]  against the learned p_W, n_W; NaN where
                           p_W_truth is NaN

Readers count rows with has_truth (and, for the errors, finite values), never average NaN
as zero (summarize_truth shows how).
"""

from __future__ import annotations

import numpy as np

TRUTH_COLUMNS = ("has_truth", "p_W_truth", "n_W_truth", "fn_truth", "point_error", "normal_error_deg")


def empty_columns() -> dict:
    """The truth columns of an empty table (see the module docstring)."""
    z3, z = np.zeros((0, 3)), np.zeros(0)
    return {"has_truth": np.zeros(0, dtype=bool), "p_W_truth": z3, "n_W_truth": z3, "fn_truth": z,
            "point_error": z, "normal_error_deg": z}


def absent(k: int) -> dict:
    """The truth columns of k rows on a step that is not sampled."""
    nan3, nan = np.full((k, 3), np.nan), np.full(k, np.nan)
    return {"has_truth": np.zeros(k, dtype=bool), "p_W_truth": nan3, "n_W_truth": nan3.copy(), "fn_truth": nan,
            "point_error": nan.copy(), "normal_error_deg": nan.copy()}


class ShadowTruth:
    """Drake's static answer for learned pairs, every `every_steps` steps.

    types: each container's ISO type code (scene order); modulus [Pa] of both boxes (the
    containers' hydroelastic modulus in the closed loop)."""

    def __init__(self, types, modulus: float, every_steps: int):
        self._types = list(types)
        self._modulus = modulus
        self.every_steps = int(every_steps)
        self._pairs: dict = {}  # (type_a, type_b) -> ContainerPair, built on first use

    def due(self, step: int) -> bool:
        """Whether `step` is sampled."""
        return step % self.every_steps == 0

    def columns(self, step: int, last: dict) -> dict:
        """The truth columns for the rows of `last` (LearnedDynamics.last()) at `step`."""
        return self.answer(last) if self.due(step) else absent(len(last["pairs"]))

    def answer(self, last: dict) -> dict:
        """Drake's static hydroelastic answer at each pair's relative pose, in W (all rows)."""
        from pydrake.geometry import HydroelasticContactRepresentation

        from testbed.contact_geometry import angle_between, static_pressure, surface_face_arrays
        from testbed.pair_plant import ContainerPair

        k = len(last["pairs"])
        p_W, n_W, fn = np.full((k, 3), np.nan), np.full((k, 3), np.nan), np.zeros(k)
        for row, (i, j) in enumerate(last["pairs"]):
            key = (self._types[i], self._types[j])
            pair = self._pairs.get(key)
            if pair is None:
                pair = self._pairs[key] = ContainerPair(*key, modulus=self._modulus)
            query = pair.set_pose(last["p_AB"][row], last["R_AB"][row])
            surfaces = query.ComputeContactSurfaces(HydroelasticContactRepresentation.kPolygon)
            if surfaces:
                s = static_pressure(surface_face_arrays(surfaces[0]))
                sign = 1.0 if pair.gid_a == surfaces[0].id_M() else -1.0  # force on M
                p_W[row] = last["p_WA"][row] + last["R_WA"][row] @ s.cop
                n_W[row] = last["R_WA"][row] @ (-sign * s.normal)
                fn[row] = float(np.linalg.norm(s.force))
        return {"has_truth": np.ones(k, dtype=bool), "p_W_truth": p_W, "n_W_truth": n_W, "fn_truth": fn,
                "point_error": np.linalg.norm(p_W - last["p_W"], axis=1),
                "normal_error_deg": np.degrees(angle_between(last["n_W"], n_W))}


def summarize_truth(table: dict, every_steps: int) -> dict:
    """Summary figures of the `closed_loop` table's truth columns: counts first (rows,
    rows with a truth answer, sampled rows where Drake found no surface), then the error
    medians and maxima over the rows where they are defined, and the largest relative
    force error over the rows where Drake's force is positive."""
    has = np.asarray(table["has_truth"], dtype=bool)
    out = {"closed_loop_rows": int(len(has)), "closed_loop_truth_every_steps": int(every_steps),
           "closed_loop_truth_rows": int(has.sum()),
           "closed_loop_truth_no_surface_rows": int(np.count_nonzero(has & ~(table["fn_truth"] > 0)))}
    for column, unit in (("point_error", "m"), ("normal_error_deg", "deg")):
        v = table[column][has & np.isfinite(table[column])]
        if v.size:
            name = column.replace("_deg", "")
            out[f"closed_loop_{name}_rows"] = int(v.size)
            out[f"closed_loop_{name}_median_{unit}"] = float(np.median(v))
            out[f"closed_loop_{name}_max_{unit}"] = float(v.max())
    ok = has & (table["fn_truth"] > 0)
    if np.any(ok):
        out["closed_loop_force_error_max_rel"] = float(np.max(np.abs(table["fn"][ok] / table["fn_truth"][ok] - 1)))
    return out
