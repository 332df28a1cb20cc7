"""Where a learned closed-loop run's wall time goes (compare.json's `cost_learned`).

The `learned_dynamics` system adds up perf_counter time in its own calc and in the
predictor's call (LearnedDynamics.costs); runs.run_variant zeroes those counters after
Simulator.Initialize and reads them after the timed steps, so they cover exactly the
AdvanceTo calls whose wall time the run reports. The parts [s]:

  predictor_s       the predictor's batched call (one per step with candidate pairs)
  learned_system_s  the rest of the system's calc and its anchors' update: reading the
                    state, the candidate pairs, the force law's kernels, writing the
                    spatial forces and the stick anchors
  recording_s       the system's own records (closed_loop rows, shadow truth); 0 in
                    twin runs, which drop the recorders
  drake_step_s      everything else in the simulator's steps: Drake's discrete update
                    (the quay's contact, the contact solver, the integrator), the
                    simulator's own bookkeeping and the framework's calls into the Python
                    system (its dispatch, which no timer inside the system sees)
                    = wall_s - the three above

All are >= 0 and sum to wall_s (drake_step_s is the remainder, so rounding of the
timers is all it can absorb). Per-step figures divide by `steps` (the plant steps run).

real_time_factor and us_per_step turn a run's wall time per simulated second (compare.json's
wall_per_sim_s_learned, wall_per_sim_s_truth) into the figures the report and the printed
lines show: one measurement, two readings.
"""

from __future__ import annotations

PARTS = ("drake_step", "learned_system", "predictor", "recording")
LABELS = {"drake_step": "Drake's step", "learned_system": "learned system", "predictor": "predictor",
          "recording": "recording"}


def breakdown(costs: dict, wall_s: float, steps: int) -> dict:
    """compare.json's `cost_learned` from LearnedDynamics.costs() over a run of wall_s [s]
    and `steps` plant steps: the four parts [s], wall_s, steps, the call counts (and
    predictor_pairs, the pair-steps asked), each part's fraction of wall_s and [us] per step."""
    calc, predict, record = costs["calc_s"], costs["predict_s"], costs["record_s"]
    out = {"wall_s": float(wall_s), "steps": int(steps),
           "predictor_s": predict, "learned_system_s": max(0.0, calc - predict), "recording_s": record,
           "drake_step_s": max(0.0, wall_s - calc - record),
           "calc_calls": costs["calc_calls"], "predictor_calls": costs["predict_calls"],
           "predictor_pairs": costs.get("predict_pairs", 0)}
    for part in PARTS:
        out[f"{part}_fraction"] = out[f"{part}_s"] / wall_s if wall_s > 0 else float("nan")
        out[f"{part}_us_per_step"] = 1e6 * out[f"{part}_s"] / steps if steps else float("nan")
    return out


def breakdown_line(cost: dict | None) -> str | None:
    """'Drake's step 61% (180 us/step), learned system 27% (...), predictor 12% (...)'
    (recording only when it is not zero); None without a breakdown."""
    if not cost:
        return None
    parts = [p for p in PARTS if p != "recording" or cost.get("recording_s", 0) > 0]
    return ", ".join(f"{LABELS[p]} {cost[f'{p}_fraction']:.0%} ({cost[f'{p}_us_per_step']:.0f} us/step)" for p in parts)


def real_time_factor(wall_per_sim_s: float) -> float:
    """Simulated time per wall time (compare.json's wall_per_sim_s of a run, inverted: > 1 runs
    faster than real time); inf for a run that took no measurable wall time."""
    return 1.0 / wall_per_sim_s if wall_per_sim_s > 0 else float("inf")


def us_per_step(wall_per_sim_s: float, time_step_s: float) -> float:
    """[us] the wall time of one plant step, from compare.json's wall_per_sim_s [s per simulated
    s] and time_step_s [s]: the same measurement as the real-time factor, per step."""
    return 1e6 * wall_per_sim_s * time_step_s
