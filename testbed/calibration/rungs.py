"""The truth ladder on real cube tosses: does a better-converged ground truth fit reality better?

Each rung rolls out the held-out tosses (the shipped split: 0.5, seed 0; 138 tosses of
even.npz) with the shipped hydroelastic parameter file, changed in one setting only:

  polygon    the file as shipped (Drake's discrete solver, each contact polygon's force at its
             centroid: the one-point rule)
  triangle   contact_surface_representation: triangle (each polygon split around its centroid,
             one point per triangle: half the one-point rule's moment error on a tilted face)
  half_step  the plant's time step halved (what the time discretisation alone moves)

The continuous-time rung (exact moments) is not run on the tosses: its contact dissipation is
Hunt-Crossley where the file's was fitted as SAP's relaxation time, so it would change the
damping model, not only the quadrature; a fair comparison needs a fit of its own.

Figures: the mean position error over the tosses in cube widths (Acosta, Yang and Posa 2022's
metric; testbed.calibration.rollout), its median, the rotation error [deg] and the wall time.
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

from testbed.calibration.data import SHIPPED_TOSSES, load_tosses
from testbed.calibration.evaluate import RolloutPool, summarize
from testbed.calibration.params_file import from_fragment
from testbed.calibration.split import train_test_split

SHIPPED_PARAMS = Path(__file__).resolve().parent / "cube_toss_hydroelastic.yaml"
RUNGS = ("polygon", "triangle", "half_step")
SPLIT, SPLIT_SEED = 0.5, 0  # the split the shipped file was fitted on (its header)


def rung_params(base, rung: str):
    """The CubeTossParams of `rung` (RUNGS) derived from `base`."""
    if rung == "polygon":
        return base
    if rung == "triangle":
        return dataclasses.replace(base, contact_surface_representation="triangle")
    if rung == "half_step":
        return dataclasses.replace(base, time_step=base.time_step / 2.0)
    raise ValueError(f"unknown rung {rung!r}; expected one of {', '.join(RUNGS)}")


def toss_ladder(rungs=RUNGS, *, params_path=SHIPPED_PARAMS, data_path=SHIPPED_TOSSES, workers: int = 2,
                limit: int | None = None) -> dict:
    """{rung: metrics (testbed.calibration.evaluate.summarize) on the held-out tosses}; `limit`:
    the first `limit` held-out tosses only (a quick check)."""
    base = from_fragment(params_path)
    data = load_tosses(data_path)
    _, held_out = train_test_split(data.tosses, SPLIT, SPLIT_SEED)
    held_out = list(held_out)[:limit] if limit else list(held_out)
    out = {}
    with RolloutPool(data, workers) as pool:
        for rung in rungs:
            start = time.perf_counter()
            results = pool.evaluate(rung_params(base, rung), held_out)
            out[rung] = summarize(results, time.perf_counter() - start)
            out[rung]["position_error_per_toss"] = [r.position_error for r in results]
    return out
