"""`testbed compare`'s verdict: the closed-loop gates of `testbed validate` on one twin run.

The gates are testbed.gates.closed_loop's, as validate judges them: the same thresholds
and pinned known limits, judged on the scene result that `case_result` builds from the twin
run's figures and trajectories.npz, whatever predictor ran in the loop (validate gates only
the shipped default; compare judges the one it ran).

compare.json `verdict`, and the exit status `testbed compare` returns (`exit_status`):
  DIVERGED    the learned run blew up (testbed/compare/metrics.py: the run failed, its
              state went non-finite, a container sank 0.1 m into another or the quay, or
              it created energy beyond the truth's)                                   -> 3
  FAIL        it ran to the end and a gate failed                                    -> 3
  PASS        it ran to the end and every judged gate held                           -> 0
              (a knife-edge scene of closed_loop.FAMILY_JUDGED has no final-pose gate here: the
              verdict line says so and names the family whose campaign judges it)
  NOT JUDGED  the learned model made no contact decision (0 container-container
              pair-steps: one container, or none ever near another), so the twin runs
              are the same physics and their agreement says nothing of the predictor -> 0
The resting-drift gate is judged only on the resting scenes run >= MIN_DRIFT_DURATION_S;
`gates_not_judged` says why it is left out otherwise.

In-scene gates: when the figures carry an "in_scene" entry (testbed.compare.in_scene.in_scene_figures:
the predictor asked at every recorded step of Drake's hydroelastic run of the scene), its gates
(testbed.gates.in_scene, the ones `testbed bench` and the validation scene case apply) join the
closed-loop ones: a failed in-scene gate is a FAIL (exit status 3), as a failed closed-loop gate.
"""

from __future__ import annotations

from testbed.gates import format_value
from testbed.gates.closed_loop import (
    FAMILY_GATES,
    FAMILY_JUDGED,
    MIN_DRIFT_DURATION_S,
    RESTING_SCENES,
    case_result,
    judge as closed_loop_gates,
)
from testbed.gates.in_scene import GATE_NAME as IN_SCENE_GATE, in_scene_gates

PASS, FAIL, DIVERGED, NOT_JUDGED = "PASS", "FAIL", "DIVERGED", "NOT JUDGED"
EXIT_STATUS = {PASS: 0, NOT_JUDGED: 0, FAIL: 3, DIVERGED: 3}  # 3: a gate failed, as `testbed validate`


def judge(figures: dict, directory, runs=None) -> dict:
    """The verdict keys compare.json gains, from a twin run's figures (compare_figures plus
    twin.py's) and its directory holding trajectories.npz (`runs`, the twin-run callback's
    trajectories, is not needed): verdict, exit_status, gates (the
    Gate dicts, named without the case prefix), gates_not_judged {gate: why},
    gates_failed [names], gates_known_limits [names of gates that held only within a pinned
    known limit's band], leaves_truth_at_s [s] (first record 2 cm from the truth; None:
    never), energy_gain_gated_J and energy_limit_J [J]. When figures carry "in_scene" (the
    in-scene figures, testbed.gates.in_scene), its gates follow the closed-loop ones."""
    s = case_result(figures["scene"], figures["duration_s"], [("run", figures, directory)])
    gates = closed_loop_gates(s, s["predictors"]["run"], "")
    not_judged = {}
    if figures.get("in_scene") is not None:
        scene_gates = in_scene_gates(figures["in_scene"])
        gates += scene_gates
        if not scene_gates:
            not_judged[IN_SCENE_GATE] = "no container pair was asked in Drake's hydroelastic run of the scene"
    if figures["scene"] in FAMILY_JUDGED:
        family, why = FAMILY_JUDGED[figures["scene"]]
        for gate in FAMILY_GATES:
            not_judged[gate] = (f"a knife-edge scene, where one trajectory is no reference ({why}); its family judges "
                                f"the final pose: testbed campaign {family}")
    if not s["resting"]:
        not_judged["resting drift"] = f"not a scene that ends at rest; those are {', '.join(RESTING_SCENES)}"
    elif s["duration_s"] < MIN_DRIFT_DURATION_S:
        not_judged["resting drift"] = f"run shorter than {MIN_DRIFT_DURATION_S:g} s"
    failed = [g.name for g in gates if not g.passed]
    pinned = [g.name for g in gates if g.passed and g.known_limit is not None]
    if figures.get("pair_steps_learned", 0) == 0:
        verdict = NOT_JUDGED
    elif figures["diverged"]:
        verdict = DIVERGED
    else:
        verdict = FAIL if failed else PASS
    f = s["predictors"]["run"]
    return {"verdict": verdict, "exit_status": EXIT_STATUS[verdict], "gates": [g.to_dict() for g in gates],
            "gates_not_judged": not_judged, "gates_failed": failed, "gates_known_limits": pinned,
            "leaves_truth_at_s": f["leaves_truth_at_s"],
            "energy_gain_gated_J": f["energy_gain_gated_J"], "energy_limit_J": s["energy_limit_J"]}


def blow_up(f: dict) -> str:
    """Why a DIVERGED run is called a blow-up, from compare.json figures `f`."""
    if f.get("learned_error"):
        error = f["learned_error"]
        return f"failed at t = {f['simulated_s_learned']:g} s: {error[:90]}{'...' if len(error) > 90 else ''}"
    if not f["max_penetration_m"] < float("inf"):
        return "its state went non-finite"
    if f["max_penetration_m"] > 0.1:
        return f"a container sank {f['max_penetration_m'] * 1e3:.0f} mm into another or the quay"
    return f"it created {f['energy_excess_J']:.3g} J more energy than the truth"


def headline(f: dict) -> str:
    """What happened to the run under test, e.g. 'ran; ended 0.041 mm from the truth'."""
    if f["verdict"] == NOT_JUDGED:
        n = f.get("container_pairs", 0)
        why = "the scene has no pair of containers to decide" if n == 0 else f"no container came near another ({n} pair(s) watched)"
        return f"ran; the learned model made no contact decision (0 container-container pair-steps: {why})"
    if f["verdict"] == DIVERGED:
        return f"DIVERGED ({blow_up(f)})"
    return f"ran; ended {mm(f['final_position_error_max_m'])} mm from the truth"


def mm(value_m: float) -> str:
    """A length [m] in mm: 3 significant digits (0.00371), whole mm from 1 m up (1744)."""
    value = value_m * 1e3
    return f"{value:.0f}" if abs(value) >= 1000 else f"{value:.3g}"


def _shown(value, unit: str) -> str:
    if isinstance(value, list):  # a pinned band
        return "[" + ", ".join(_shown(v, unit) for v in value) + "]"
    if unit == "m" and isinstance(value, float) and value == value:
        return f"{mm(value)} mm"
    text = format_value(value, unit)
    return text if unit in ("", "m") or text == "n/a" else f"{text} {unit}"


def gate_line(g: dict) -> str:
    """'    PASS  final position: 0.04 mm (limit 20.00 mm)'."""
    mark = "PASS" if g["passed"] else "FAIL"
    if isinstance(g["value"], bool):
        return f"    {mark}  {g['name']}"
    kind = "pinned band" if isinstance(g["threshold"], list) else "limit"
    return f"    {mark}  {g['name']}: {_shown(g['value'], g['unit'])} ({kind} {_shown(g['threshold'], g['unit'])})"


def speed(ratio, against: str) -> str:
    """'2.1x faster than X' or '1.5x slower than X' from ratio = wall(X) / wall(run)."""
    if ratio is None or not ratio > 0:
        return f"speed vs {against} n/a"
    return f"{ratio:.2g}x faster than {against}" if ratio >= 1 else f"{1 / ratio:.2g}x slower than {against}"


def verdict_lines(f: dict) -> list[str]:
    """The gate lines, the speed-ups and the final verdict line `testbed compare` prints."""
    if f["verdict"] == NOT_JUDGED:
        return ["  closed-loop gates: not judged: with 0 pair-steps the learned run is Drake's own physics "
                "(its position error of 0 is no score); `testbed scenes` marks the scenes with container-container "
                "contact",
                f"verdict: {NOT_JUDGED} (exit status 0)"]
    lines = ["  closed-loop gates (testbed validate's, testbed/gates/closed_loop.py):"]
    lines += [gate_line(g) for g in f["gates"]]
    lines += [f"    --    {name}: not judged ({why})" for name, why in f["gates_not_judged"].items()]
    ratios = [speed(f.get("speedup_vs_truth"), "Drake hydroelastic")]
    if "speedup_vs_point" in f:
        ratios.append(speed(f["speedup_vs_point"], "Drake point"))
    lines.append(f"  speed (wall time per simulated second): {', '.join(ratios)}")
    total, failed = len(f["gates"]), list(f["gates_failed"])
    if failed:
        counted = f"{len(failed)} of {total} gates failed: {', '.join(failed)}"
    else:
        counted = f"all {total} gates passed"
    if f.get("gates_known_limits"):
        counted += (f"; {len(f['gates_known_limits'])} passed only within pinned known limits, far outside the "
                    "bounds (see each gate)")
    family = [g for g in FAMILY_GATES if g in f.get("gates_not_judged", {})]
    if family:
        counted += f"; the {' and '.join(family)} NOT judged here: {f['gates_not_judged'][family[0]].split(': ')[-1]}"
    lines.append(f"verdict: {f['verdict']}: {counted} (exit status {f['exit_status']})")
    return lines

