"""The closed loop's shadow truth: Drake's static hydroelastic answer at the learned pairs' poses.

With `contact_log` and `learned_dynamics.shadow_truth`, the `closed_loop` table carries,
next to the learned answer of every active pair, Drake's static hydroelastic answer for
the same relative pose (a testbed.contact.pair_plant.ContainerPair plant per size pair, at the
containers' modulus). Computing it is ~0.25 ms per pair (ComputeContactSurfaces and the
per-face reads of testbed.contact.surfaces.surface_face_arrays): on every step it made a
9-high stack's logged run 7.3x the bare closed loop. So it is SAMPLED: computed on the
steps whose number is a multiple of `truth_every_steps` (step = round(t / h); step 0
included; default 20) and absent on the others (2.1x; 1.7x with no truth at all: the
rest is contact_log's own records). Every row still carries the columns:

  has_truth (k,) bool      True: this row's step was sampled and the truth computed on its
                           own state (never held from an earlier step)
  p_W_truth, n_W_truth (k, 3) [m], [-]  Drake's centre of pressure (the exact integral of its
                           pressure field over its contact surface) and unit normal (A -> B)
                           in W; NaN where has_truth is False or Drake finds no contact
                           surface at that pose
  truth_gap (k,) [m]       |p_W_truth - the one-point rule's centre of pressure|: the truth's
                           own discretisation error at that pose (NaN likewise)
  fn_truth (k,) [N]        Drake's static normal force; NaN where has_truth is False, 0 where
                           sampled and Drake finds no surface
  point_error (k,) [m], normal_error_deg (k,) [deg]  against the learned p_W, n_W; NaN where
                           p_W_truth is NaN

Readers count rows with has_truth (and, for the errors, finite values), never average NaN
as zero (summarize_truth shows how).
"""

from __future__ import annotations

import numpy as np

from testbed.contact.pair_plant import ContainerPair
from testbed.contact.surfaces import angle_between, static_pressure, surface_face_arrays

TRUTH_COLUMNS = ("has_truth", "p_W_truth", "n_W_truth", "fn_truth", "point_error", "normal_error_deg", "truth_gap")


def empty_columns() -> dict:
    """The truth columns of an empty table (see the module docstring)."""
    z3, z = np.zeros((0, 3)), np.zeros(0)
    return {"has_truth": np.zeros(0, dtype=bool), "p_W_truth": z3, "n_W_truth": z3, "fn_truth": z,
            "point_error": z, "normal_error_deg": z, "truth_gap": z}


def absent(k: int) -> dict:
    """The truth columns of k rows on a step that is not sampled."""
    nan3, nan = np.full((k, 3), np.nan), np.full(k, np.nan)
    return {"has_truth": np.zeros(k, dtype=bool), "p_W_truth": nan3, "n_W_truth": nan3.copy(), "fn_truth": nan,
            "point_error": nan.copy(), "normal_error_deg": nan.copy(), "truth_gap": nan.copy()}


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


        k = len(last["pairs"])
        p_W, n_W, fn = np.full((k, 3), np.nan), np.full((k, 3), np.nan), np.zeros(k)
        gap = np.full(k, np.nan)
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
                gap[row] = float(np.linalg.norm(s.cop - s.cop_one_point))
        return {"has_truth": np.ones(k, dtype=bool), "p_W_truth": p_W, "n_W_truth": n_W, "fn_truth": fn,
                "point_error": np.linalg.norm(p_W - last["p_W"], axis=1),
                "normal_error_deg": np.degrees(angle_between(last["n_W"], n_W)), "truth_gap": gap}


def summarize_truth(table: dict, every_steps: int) -> dict:
    """Summary figures of the `closed_loop` table's truth columns: counts first (rows,
    rows with a truth answer, sampled rows where Drake found no surface), then the error
    medians and maxima over the rows where they are defined, and the largest relative
    force error over the rows where Drake's force is positive."""
    has = np.asarray(table["has_truth"], dtype=bool)
    out = {"closed_loop_rows": int(len(has)), "closed_loop_truth_every_steps": int(every_steps),
           "closed_loop_truth_rows": int(has.sum()),
           "closed_loop_truth_no_surface_rows": int(np.count_nonzero(has & ~(table["fn_truth"] > 0)))}
    for column, unit in (("point_error", "m"), ("normal_error_deg", "deg"), ("truth_gap", "m")):
        if column not in table:
            continue
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


LEARNED_COLUMNS = ("a", "b", "p_W", "n_W", "fn", "f_W", "area")


class ClosedLoopRecords:
    """The `closed_loop` table, gathered at little cost per step: a step keeps references
    to the system's arrays of its candidate pairs (fresh arrays every step, never
    written again), and build() selects the touching rows (fn > 0) and concatenates
    every column once. On the sampled steps the truth is computed at once, on the
    touching rows of that step's state.

    rows: (m,) each container's index into the run's body_names; truth: a ShadowTruth or
    None (no truth columns)."""

    def __init__(self, rows, truth: ShadowTruth | None):
        self._rows = np.asarray(rows)
        self.truth = truth
        self._steps: list = []  # (step, time, (ia, ib, fn, p_W, n_W, f_W, area), truth columns | None)

    def add(self, step: int, time: float, pairs: tuple, truth: dict | None = None) -> None:
        """One step's candidate pairs: ia, ib (k,) container indices, fn (k,) [N] (0: not
        touching), p_W, n_W, f_W (k, 3), area (k,); truth: the truth columns of the
        touching rows, in order (a sampled step), else None."""
        if len(pairs[0]):
            self._steps.append((step, time, pairs, truth))

    def build(self) -> dict:
        """The table (columns of the module docstring and LEARNED_COLUMNS, plus step, time)."""
        empty = {"a": np.zeros(0, dtype=int), "b": np.zeros(0, dtype=int), "p_W": np.zeros((0, 3)),
                 "n_W": np.zeros((0, 3)), "fn": np.zeros(0), "f_W": np.zeros((0, 3)), "area": np.zeros(0)}
        if self.truth is not None:
            empty.update(empty_columns())
        if not self._steps:
            return {**empty, "step": np.zeros(0, dtype=np.int64), "time": np.zeros(0)}
        counts = np.array([len(s[2][0]) for s in self._steps])
        ia, ib, fn, p_W, n_W, f_W, area = (np.concatenate([s[2][c] for s in self._steps]) for c in range(7))
        keep = fn > 0
        out = {"a": self._rows[ia[keep]], "b": self._rows[ib[keep]], "p_W": p_W[keep], "n_W": n_W[keep],
               "fn": fn[keep], "f_W": f_W[keep], "area": area[keep]}
        if self.truth is not None:
            kept = np.add.reduceat(keep, np.r_[0, np.cumsum(counts)[:-1]])  # touching rows per step
            start = np.r_[0, np.cumsum(kept)[:-1]]
            columns = absent(int(keep.sum()))
            for (_, _, _, truth), lo, n in zip(self._steps, start, kept):
                if truth is not None:
                    assert len(truth["has_truth"]) == n  # the truth of exactly this step's touching rows
                    for name in TRUTH_COLUMNS:
                        columns[name][lo:lo + n] = truth[name]
            out.update(columns)
        out["step"] = np.repeat(np.array([s[0] for s in self._steps], dtype=np.int64), counts)[keep]
        out["time"] = np.repeat(np.array([s[1] for s in self._steps]), counts)[keep]
        return out
