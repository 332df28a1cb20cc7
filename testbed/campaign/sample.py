"""One sample of a campaign: the truth (the scene's own reference: Drake's discrete plant, or its
continuous one where the scene says so), the truth again from a start perturbed by PERTURB_M (the varied
containers moved along world x), and the candidate (the learned loop with a predictor, or Drake point
contact), all from the sample's initial state; what each decides (its outcome class) and how far the
candidate ends from the truth.

Outcome classes, from the runs' records (first that applies): diverged (the run failed), moving (a free
container faster than MOVING_MPS at the end: still sliding or falling; a
stack swaying after an impact, ~5 cm/s, is not), fell (one ends more than FELL_M below its start: off a stack),
tipped (one turned more than TIPPED_DEG from its start), slid (one moved more than SLID_M sideways), seated.

The truth is well posed where its perturbed twin ends within WELL_POSED_M of it (the start moved 1 mm, below
every gate's resolution): there the candidate is judged by the closed-loop gates' distance (final position
within 2 cm and angle within 0.5 deg of the truth) and by its outcome; where the truth is sensitive, by its
outcome alone (the truth's own end is not known better than its spread).
"""

from __future__ import annotations

import math
import time

import numpy as np

from testbed.campaign.family import checked_sample, load_family
from testbed.compare.run_candidates import reference_run
from testbed.compare.runs import run_variant, variant
from testbed.gates.closed_loop import FINAL_ANGLE_TOL_DEG, FINAL_POSITION_TOL_M
from testbed.geometry.rotations import angle_between_quaternions_deg

PERTURB_M = 1e-3  # [m] the truth's perturbed start (the varied containers along world x: perturbation)
WELL_POSED_M = 5e-3  # [m] the perturbed truth's end within this of the truth's: well posed (amplification <= 5)
MOVING_MPS, FELL_M, TIPPED_DEG, SLID_M = 0.25, 1.0, 30.0, 0.5
CLASSES = ("seated", "slid", "tipped", "fell", "moving", "diverged")
RECORD_EVERY = 20  # plant steps between records (20 ms at 1 ms)


def outcome(run) -> str:
    """The run's outcome class (module docstring)."""
    if run.error:
        return "diverged"
    p, q, V = run.p_WB, run.q_WB, run.V_WB
    if not len(p) or not np.all(np.isfinite(p[-1])):
        return "diverged"
    if np.max(np.linalg.norm(V[-1, :, 3:], axis=1), initial=0.0) > MOVING_MPS:
        return "moving"
    if np.max(p[0, :, 2] - p[-1, :, 2], initial=0.0) > FELL_M:
        return "fell"
    if np.max(angle_between_quaternions_deg(q[-1], q[0]), initial=0.0) > TIPPED_DEG:
        return "tipped"
    if np.max(np.linalg.norm(p[-1, :, :2] - p[0, :, :2], axis=1), initial=0.0) > SLID_M:
        return "slid"
    return "seated"


def _apart(a, b) -> tuple[float, float]:
    """(largest final position distance [m], largest final orientation angle [deg]) over the free containers."""
    n = min(a.p_WB.shape[1], b.p_WB.shape[1])
    if not len(a.p_WB) or not len(b.p_WB):
        return math.inf, math.inf
    d = np.linalg.norm(a.p_WB[-1, :n] - b.p_WB[-1, :n], axis=1)
    ang = angle_between_quaternions_deg(a.q_WB[-1, :n], b.q_WB[-1, :n])
    return float(np.max(d, initial=0.0)), float(np.max(ang, initial=0.0))


def perturbation(scenario, varied_paths) -> list[str]:
    """--set overrides moving the start of the free containers the family varies (containers[i] in its
    field paths; none: the last free container) PERTURB_M along world x. Not every free container: moving
    a whole scene along the quay is a symmetry, and its twin would end exactly PERTURB_M away."""
    import re

    free = [i for i, c in enumerate(scenario.containers) if not c.fixed]
    named = sorted({int(m) for p in varied_paths for m in re.findall(r"^containers\[(\d+)\]", p)} & set(free))
    chosen = named or free[-1:]
    return [f"containers[{i}].X_WC.translation[0]={float(scenario.containers[i].pose().translation()[0]) + PERTURB_M!r}"
            for i in chosen]


def judge(scenario, twin_scenario, duration: float, candidate: str) -> dict:
    """The sample's record: outcome classes, distances, well-posedness, agreement (module docstring);
    twin_scenario: the same with the perturbed start. candidate: "point" (Drake point contact) or a
    predictor spec for the learned loop."""
    t0 = time.perf_counter()
    truth = reference_run(variant(scenario, "truth"), duration, RECORD_EVERY)[0]
    twin = reference_run(variant(twin_scenario, "truth"), duration, RECORD_EVERY)[0]
    kind, predictor = ("point", None) if candidate == "point" else ("learned", candidate)
    run = run_variant(variant(scenario, kind, predictor), duration, RECORD_EVERY)
    spread, _ = _apart(truth, twin)
    error, angle = _apart(run, truth)
    classes = {"truth": outcome(truth), "truth_perturbed": outcome(twin), "candidate": outcome(run)}
    well_posed = spread <= WELL_POSED_M and classes["truth"] == classes["truth_perturbed"]
    same = classes["candidate"] == classes["truth"]
    within = error <= FINAL_POSITION_TOL_M and angle <= FINAL_ANGLE_TOL_DEG
    return {"classes": classes, "truth_spread_m": spread, "final_error_m": error, "final_angle_deg": angle,
            "well_posed": bool(well_posed), "agree": bool(same and (within or not well_posed)),
            "candidate_error": run.error, "wall_s": time.perf_counter() - t0}


def run_sample(item: dict) -> dict:
    """A worker's call (testbed.validation.executors.map_calls): item {"family": path, "sample": {...},
    "candidate", "duration"} -> the sample with its status ("refused" | "ok" | "error") and record."""
    sample = item["sample"]
    family = load_family(item["family"])
    scenario, refused = checked_sample(family, sample)
    if refused:
        return {**sample, "status": "refused", "refused": refused}
    try:
        moved = perturbation(scenario, [v.path for v in family.varied])
        twin, _ = checked_sample(family, {**sample, "overrides": sample["overrides"] + moved})
        return {**sample, "status": "ok", **judge(scenario, twin, item["duration"], item["candidate"])}
    except Exception as e:  # noqa: BLE001 - one sample's failure is its record; the campaign goes on
        return {**sample, "status": "error", "error": f"{type(e).__name__}: {e}".splitlines()[0]}
