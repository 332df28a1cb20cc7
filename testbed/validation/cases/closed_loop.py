"""Case kind `closed_loop`: the learned contact model drives the simulation (issue 10, section 5).

One case per scene: Drake's ground truth (the scene's own hydroelastic model), Drake's
point contact (for its speed) and the `learned_dynamics` closed loop with each predictor,
all from the same initial state in one process (testbed.compare.compare_predictors, one
truth run shared by the predictors). Gates judge the improved predictor only; the
paper's MLP is reported, not gated (where it cannot hold a stack, the table shows it).
Sections: a one-line verdict near the top of the report, and the table of figures with
the speed ratios and a verdict per scene.

Scenes where the contact point or normal decides the outcome (issue 23; closed forms in
their YAML and tests/closed_loop/test_closed_loop_scenes.py): overhang_hold (an empty 20 ft box with its
centre of mass 0.1 m inside the welded lower box's edge: holds), overhang_tip (0.1 m outside:
tips about the edge, 10 deg at ~1 s) and stack_slide_rest (slides 1.147 m to rest: a tilted
normal changes the stopping distance). On the overhang pair an outcome gate adds: the learned
run's box tips iff the truth's does. tests/closed_loop/test_closed_loop_alternatives.py shows that simple
alternatives (points biased 5 / 30 cm toward the overhang, normals tilted 1 deg, the geometric
prior alone, Drake point contact's answer) fail these gates, and that the shipped predictor and
Drake hydroelastic's own static answer pass them.
"""

from __future__ import annotations

import math

from learned_contact import sources
from testbed.bodies.containers import HYDROELASTIC_MODULUS
from testbed.compare import compare_predictors
from testbed.compare.costs import breakdown_line
from testbed.document import Bullets, Section, Text, table
from testbed.effects.learned_dynamics.force_law import KAPPA_MODULUS
from testbed.geometry.rotations import angle_between_quaternions_deg
from testbed.validation.cases import Case, CaseKind, register
from testbed.validation.gates import Gate
from testbed.validation.sensitivity import SENSITIVITY_CHECK

SENSITIVITY_LABEL = "improved, every point +5 cm along A's x (sensitivity check)"
PREDICTORS = sources.SHIPPED_NAMES  # ("improved", "paper")
GATED = "improved"
# Issue 10, section 5 (the starting values; none is loosened here).
FINAL_POSITION_TOL_M = 0.02  # final position of every container within 2 cm of the truth's
FINAL_ANGLE_TOL_DEG = 0.5  # final orientation within 0.5 deg of the truth's
MAX_PENETRATION_M = 0.020  # deepest container-container (SAT) or container-quay penetration
# Known limits, pinned like the stress suite's expected failures: the gate holds while the
# figure stays in the band around the pinned one (worse, or much better, fails).
# scene -> (why, {gate: (pinned figure, (low, high) band factors)}).
KNOWN_LIMITS = {
    "crane_edge_landing": (
        "the load lands with its centre of mass over the stack's edge and tips off after the twistlocks "
        "release, in the ground truth and in the closed loop alike: where it comes to rest is a balance-point "
        "outcome (MuJoCo with matched contact, identical until the release, ends 6.5 m away too), and Drake's own "
        "hydroelastic ground truth penetrates 39.5 mm on this edge-first landing, above the 20 mm bound",
        {"final position": (1.008, (0.5, 2.0)), "final angle": (5.3, (0.5, 2.0)),
         "max penetration": (0.0457, (0.8, 1.25))}),
}
# Outcome gate (issue 23) on the scenes where the contact point decides whether a box holds or
# tips: a run 'tips' when a free container's final orientation is more than TIP_ANGLE_DEG from its
# initial one; the learned run must tip iff the truth's does. 5 deg lies between what holding
# boxes reach (Drake hydroelastic on overhang_hold: 0.24 deg, rocking from the flat start) and
# where the tipping one is at the end (overhang_tip at 0.9 s: 8 deg; the rigid closed form
# reaches 5 deg at 0.90 s, Drake hydroelastic at 0.71 s).
TIP_ANGLE_DEG = 5.0
OUTCOME_SCENES = ("overhang_hold", "overhang_tip")
# How much each of those scenes discriminates: the smallest change to the shipped predictor that
# fails the scene's gates, by bisection (every point moved along the overhang axis, A's x, or every
# normal tilted toward it; tests/closed_loop_alternatives.py), measured with these gates and durations.
DISCRIMINATION = {
    "overhang_hold": "points 24 mm away from the overhang (energy created; final position from 56 mm; the box "
                     "tips at 75-150 mm); points 5 or 30 cm toward it pass",
    "overhang_tip": "points 3 mm toward the overhang (final angle: the box tips late; the shipped predictor's own "
                    "0.39 deg is 2-3 mm of bias from the 0.5 deg bound) or 4 mm away from it (energy created)",
    "stack_slide_rest": "normals tilted 0.28 deg toward the motion (final position: slides 2 cm further); "
                        "points moved 30 cm either way pass",
}
DRIFT_TOL_M_PER_MIN = 1e-3  # resting drift: < 1 mm per simulated minute
ENERGY_FRACTION = 0.01  # E(t) - E(0) <= 1% of the scene's largest potential drop
# Resting drift is the steepest fitted slope of a container's position over the second half
# of the run (testbed.compare.metrics.drift_rate). That half must start after the settling
# transient: measured on two_stack, Drake's own drift is 0.47 mm/min over 0.25-0.5 s (still
# settling) and 1.7e-4 mm/min over 1-2 s, so the gate is judged on runs of at least 1 s.
MIN_DRIFT_DURATION_S = 1.0
# Scenes whose containers should end at rest (the crane scenes land a moving box; their
# drift is not a rest figure).
RESTING_SCENES = ("two_stack", "five_stack", "nine_mixed_stack", "bridge", "windy_stack")
# (scene, simulated duration [s]): each scene's own (crane_landing_sway lands its box at ~7.5 s,
# so it keeps its 9 s). Measured on 2 cores shared with other work (load ~4.7): ~350 s of
# worker time for all nine, ~3 min with 2 workers (nine_mixed_stack 89 s, crane_landing_sway
# ~95 s; Drake's hydroelastic run is most of it).
DEFAULT_SCENES = (("two_stack", 2.0), ("five_stack", 2.0), ("nine_mixed_stack", 5.0), ("bridge", 2.0),
                  ("windy_stack", 4.0), ("crane_misaligned", 5.0), ("crane_hard_landing", 3.0),
                  ("crane_edge_landing", 5.0), ("crane_landing_sway", 9.0),
                  # issue 23: the contact point / normal decides the outcome; ~4 s of worker time for the
                  # three (measured 2.2 + 0.8 + 0.6 s with improved and paper; the paper diverges early)
                  ("overhang_hold", 1.5), ("overhang_tip", 0.9), ("stack_slide_rest", 1.2))
SMOKE_DURATION_S = 0.3  # two_stack only: shows the section, costs ~2 s

# compare.json figures kept in the record (scalars; the rest stays in the twin-run files)
KEYS = ("diverged", "departed", "position_error_max_m", "final_position_error_max_m", "final_angle_error_max_deg",
        "angle_error_max_deg", "max_penetration_m", "max_container_penetration_m", "max_ground_penetration_m",
        "energy_gain_max_J", "energy_gain_max_truth_J", "potential_drop_max_J", "drift_m_per_min_learned",
        "drift_m_per_min_truth", "simulated_s_learned", "learned_error", "worst_container", "worst_time_s",
        "wall_per_sim_s_truth", "wall_per_sim_s_learned", "wall_per_sim_s_point", "speedup_vs_truth",
        "speedup_vs_point", "stability_max", "predictor_kind", "cost_learned")


def closed_loop_cases(scenes, suffix: str = "") -> list[Case]:
    return [Case(f"closed-{s}{suffix}", "closed_loop", {"scene": s, "duration": d, "predictors": list(PREDICTORS)})
            for s, d in scenes]


def series_figures(out_dir, tol_m: float = FINAL_POSITION_TOL_M) -> dict:
    """From a twin run's trajectories.npz: 'leaves_truth_at_s' [s], the first recorded time a
    container is more than tol_m from the truth's (None: never), and 'energy_gain_gated_J'
    [J] = max over t of (E(t) - E(0)) of the learned run minus max(0, the truth's E(t) - E(0))
    at the same t: the work an external actor (a moving crane trolley, the wind) does on the
    containers in Drake's run is not counted as energy the contact model created; for a
    passive scene the truth's E(t) - E(0) <= 0 and this is the learned run's E(t) - E(0);
    'final_tilt_max_deg' / 'final_tilt_max_truth_deg' [deg]: the largest rotation of a free
    container between its first and last recorded orientation, in the learned run / the
    truth's (what the outcome gate reads)."""
    import numpy as np


    with np.load(f"{out_dir}/trajectories.npz") as d:
        err = d["position_error"]  # (n, m) [m] learned vs truth
        t = d["learned_time"]
        over = np.flatnonzero(~(np.nan_to_num(err, nan=np.inf).max(axis=1) <= tol_m))
        n = len(t)
        gain = d["learned_energy"] - d["learned_energy"][0]  # (n,) [J]
        external = np.maximum(0.0, d["truth_energy"][:n] - d["truth_energy"][0])  # (n,) [J]
        tilt = [float(np.max(angle_between_quaternions_deg(d[f"{k}_q_WB"][-1], d[f"{k}_q_WB"][0]), initial=0.0))
                for k in ("learned", "truth")]
    excess = gain - external
    return {"leaves_truth_at_s": float(t[over[0]]) if over.size else None,
            "energy_gain_gated_J": float(np.max(np.nan_to_num(excess, nan=np.inf))),
            "final_tilt_max_deg": tilt[0], "final_tilt_max_truth_deg": tilt[1]}


def case_result(scene: str, duration: float, runs) -> dict:
    """A closed-loop case's result (what `gates` judges) from twin runs against one truth:
    runs = [(predictor, compare.json figures, the twin run's directory)]. Also used by
    `testbed compare` (testbed/validation/compare_verdict.py) to judge its run the same way."""
    out = {name: {**{k: f.get(k) for k in KEYS}, **series_figures(d)} for name, f, d in runs}
    first = runs[0][1]
    drop = first["potential_drop_max_J"]
    return {"scene": scene, "duration_s": float(duration), "time_step_s": first["time_step_s"],
            "resting": scene in RESTING_SCENES, "largest_potential_drop_J": drop,
            "energy_limit_J": ENERGY_FRACTION * drop, "predictors": out}


@register
class ClosedLoopCase(CaseKind):
    name = "closed_loop"
    order = 15
    timing_keys = ("wall_per_sim_s_truth", "wall_per_sim_s_learned", "wall_per_sim_s_point", "speedup_vs_truth",
                   "speedup_vs_point", "cost_learned")

    def cases(self, suite: str) -> list[Case]:
        if suite == "smoke":
            return closed_loop_cases([("two_stack", SMOKE_DURATION_S)])
        if suite in ("default", "full"):  # with the sensitivity check, reported beside the shipped predictors
            return [Case(c.id, c.kind, {**c.params, "predictors": [*c.params["predictors"], SENSITIVITY_CHECK]})
                    for c in closed_loop_cases(DEFAULT_SCENES)]
        return []

    def with_predictors(self, cases: list[Case], predictors: list[str]) -> list[Case]:
        """Every closed-loop scene runs the extra predictors too, against the same truth run."""
        return [Case(c.id, c.kind, {**c.params, "predictors": list(dict.fromkeys([*c.params["predictors"], *predictors]))})
                for c in cases]

    def run(self, scene: str, duration: float, predictors=PREDICTORS) -> dict:
        import tempfile

        with tempfile.TemporaryDirectory(prefix="closed-loop-") as tmp:
            dirs = [f"{tmp}/{p}" for p in predictors]
            figures = compare_predictors(scene, list(predictors), out_dirs=dirs, duration=duration, with_point=True,
                                         replay=False)
            return case_result(scene, duration, list(zip(predictors, figures, dirs)))

    def gates(self, record: dict) -> list[Gate]:
        s, cid = record["result"], record["id"]
        f = s["predictors"].get(GATED)
        if f is None:
            return []
        name = f"{cid}: {GATED}"
        gates = [
            Gate(f"{name}: no divergence", not f["diverged"], f["diverged"], False, "",
                 "the closed loop ran to the end, finite, no container 0.1 m deep, no energy created beyond the truth's"),
            Gate(f"{name}: final position", _le(f["final_position_error_max_m"], FINAL_POSITION_TOL_M),
                 f["final_position_error_max_m"], FINAL_POSITION_TOL_M, "m",
                 "largest distance of a container's final position from the ground truth's"),
            Gate(f"{name}: final angle", _le(f["final_angle_error_max_deg"], FINAL_ANGLE_TOL_DEG),
                 f["final_angle_error_max_deg"], FINAL_ANGLE_TOL_DEG, "deg",
                 "largest rotation between a container's final orientation and the ground truth's"),
            Gate(f"{name}: max penetration", _le(f["max_penetration_m"], MAX_PENETRATION_M), f["max_penetration_m"],
                 MAX_PENETRATION_M, "m", "deepest container-container (separating-axis) or container-quay penetration"),
            Gate(f"{name}: energy", _le(f["energy_gain_gated_J"], s["energy_limit_J"]), f["energy_gain_gated_J"],
                 s["energy_limit_J"], "J",
                 f"max over time of E(t) - E(0) in the closed loop, less the work a crane or the wind does in Drake's "
                 f"run; limit {ENERGY_FRACTION:.0%} of the scene's largest potential drop "
                 f"({s['largest_potential_drop_J']:.4g} J, max over t of V(0) - V(t) in Drake's run)"),
        ]
        if s["scene"] in OUTCOME_SCENES and f.get("final_tilt_max_truth_deg") is not None:
            gates.append(_outcome(name, f))
        known = KNOWN_LIMITS.get(s["scene"])
        if known is not None:
            gates = [_pinned(g, name, known) for g in gates]
        if s["resting"] and s["duration_s"] >= MIN_DRIFT_DURATION_S:
            gates.append(Gate(f"{name}: resting drift", _le(f["drift_m_per_min_learned"], DRIFT_TOL_M_PER_MIN),
                              f["drift_m_per_min_learned"], DRIFT_TOL_M_PER_MIN, "m/min",
                              "steepest fitted drift of a container over the second half of the run, per simulated minute"))
        return gates

    def sections(self, records: list[dict]) -> list[Section]:
        if not records:
            return []
        judged = [(r, self.gates(r)) for r in records]
        pinned = [r["result"]["scene"] for r, g in judged
                  if g and all(x.passed for x in g) and any(x.name.endswith("(known limit)") for x in g)]
        held = [r["result"]["scene"] for r, g in judged if g and all(x.passed for x in g)
                and r["result"]["scene"] not in pinned]
        failed = [r["result"]["scene"] for r, g in judged if g and not all(x.passed for x in g)]
        speed = [r["result"]["predictors"][GATED]["speedup_vs_truth"] for r in records
                 if GATED in r["result"]["predictors"]]
        paper = [r["result"]["scene"] for r in records if r["result"]["predictors"].get("paper", {}).get("diverged")]
        head = (f"Closed loop: the improved predictor drives {len(held)} of {len(records)} scenes within its gates"
                + (f" (fails: {', '.join(failed)})" if failed else "")
                + (f"; {', '.join(pinned)} only within pinned known limits" if pinned else "")
                + (f", at {_range(speed)}x the speed of Drake hydroelastic" if speed else "")
                + f"; the paper's MLP diverges on {len(paper)} of {len(records)}"
                + (f" ({', '.join(paper)})" if paper else "") + ".")
        blind, tell = sensitivity_split(records)
        if blind or tell:
            head += (f" Sensitivity: every point moved 5 cm still passes {len(blind)} of {len(blind) + len(tell)} scenes"
                     f"{' (only ' + ', '.join(tell) + ' tell it apart)' if tell else ''}.")
        rows = [_row(r["result"], name, f) for r in records for name, f in r["result"]["predictors"].items()]
        return [Section(None, [Text(head)], order=7), Section("Closed loop: the learned model drives the simulation", [
            Text("Each scene runs from the same initial state with Drake hydroelastic contact (the ground truth), Drake "
                 "point contact, and the learned_dynamics closed loop per predictor (Drake's container-container contact "
                 "filtered off, the quay's kept). Every run's containers are at the learned law's hydroelastic modulus, "
                 f"{KAPPA_MODULUS:.0e} Pa, not the shipped {HYDROELASTIC_MODULUS:.0e} Pa: a law as stiff as the shipped "
                 "truth is unstable in the explicit step at 1 ms on the light stacks (sdf/README.md); a scene that sets "
                 "its own modulus keeps it (overhang_hold and overhang_tip: the shipped one, at a 0.625 ms step). "
                 "Gates judge the improved predictor: no divergence, final positions "
                 f"within {FINAL_POSITION_TOL_M * 100:g} cm and {FINAL_ANGLE_TOL_DEG:g} deg of the truth's, max "
                 f"penetration < {MAX_PENETRATION_M * 1e3:g} mm, E(t) - E(0) <= {ENERGY_FRACTION:.0%} of the scene's "
                 "largest potential drop (max over t of V(0) - V(t) in Drake's run: what the scene really releases; "
                 "the work a crane trolley or the wind does in Drake's run at the same t is not counted as created), "
                 f"resting drift < {DRIFT_TOL_M_PER_MIN * 1e3:g} mm per simulated minute on resting scenes run >= "
                 f"{MIN_DRIFT_DURATION_S:g} s; on the overhang scenes, the outcome: a container's final rotation "
                 f"from its start above {TIP_ANGLE_DEG:g} deg (tips) iff the truth's. The paper's MLP is reported, not "
                 "gated. Speed = Drake's wall time per simulated second / the learned run's, measured side by side in one "
                 "process (> 1: learned faster). Where a learned run is not faster, its verdict below says where its "
                 "wall time went: Drake's step (the quay's contact, the solver, the simulator), the learned system, the "
                 "predictor (testbed/compare/costs.py)."),
            table(["scene", "predictor", "ran to [s]", "diverged", "final pos err [mm]", "final angle err [deg]",
                   "max penetration [mm]", "energy created [J] (limit)", "drift [mm/min]", "leaves truth by 2 cm at [s]",
                   "learned wall / sim s [ms]", "x vs hydroelastic", "x vs point", "final tilt [deg] (truth's)"], rows),
            Bullets(tuple(verdict(r["result"]) for r in records)),
            *_sensitivity(records),
            *_discrimination(records),
        ], order=15)]


def sensitivity_split(records: list[dict]) -> tuple[list[str], list[str]]:
    """(scenes where the sensitivity check passes every gate: they cannot tell a 5 cm bias,
    scenes where it fails some: they can), over the records that ran it."""
    kind, blind, tell = ClosedLoopCase(), [], []
    for r in records:
        f = r["result"]["predictors"].get(SENSITIVITY_CHECK)
        if f is None:
            continue
        gates = kind.gates({"id": r["id"], "result": {**r["result"], "predictors": {GATED: f}}})
        (blind if all(g.passed for g in gates) else tell).append(r["result"]["scene"])
    return blind, tell


def _sensitivity(records: list[dict]) -> list:
    blind, tell = sensitivity_split(records)
    if not blind and not tell:
        return []
    return [Text(f"Sensitivity check ({SENSITIVITY_LABEL}, testbed/validation/sensitivity.py; reported, not gated): "
                 f"it fails the gates on {len(tell)} of {len(blind) + len(tell)} scenes"
                 + (f" ({', '.join(tell)}): only these tell a model whose every contact point is 5 cm off from the "
                    "shipped one" if tell else ": no scene here tells a 5 cm bias apart")
                 + (f"; it passes {', '.join(blind)}: there the loop settles wherever the predicted point sits "
                    "under the centre of mass, so passing them says little about the point" if blind else "") + ".")]


def _discrimination(records: list[dict]) -> list:
    """What the scenes where the contact point decides the outcome can tell apart (DISCRIMINATION)."""
    scenes = [r["result"]["scene"] for r in records if r["result"]["scene"] in DISCRIMINATION]
    if not scenes:
        return []
    return [Text("Scenes where the contact point or normal decides the outcome (issue 23; closed forms in the scene "
                 "files): the smallest change to the shipped predictor that fails each scene's gates, measured:"),
            Bullets(tuple(f"{s}: {DISCRIMINATION[s]}" for s in scenes))]


def _outcome(name: str, f: dict) -> Gate:
    """The learned run tips (a free container's final rotation from its start above
    TIP_ANGLE_DEG) iff the truth's does."""
    learned, truth = f["final_tilt_max_deg"], f["final_tilt_max_truth_deg"]
    tips = truth > TIP_ANGLE_DEG
    ok = learned is not None and not math.isnan(learned) and (learned > TIP_ANGLE_DEG) == tips
    return Gate(f"{name}: outcome", ok, learned, TIP_ANGLE_DEG, "deg",
                f"tips (a container's final rotation from its start above {TIP_ANGLE_DEG:g} deg) iff the truth's does: "
                f"the truth {'tips' if tips else 'holds'} ({truth:.3g} deg)")


def _pinned(gate: Gate, prefix: str, known) -> Gate:
    """`gate` judged against its pinned band when KNOWN_LIMITS lists it for the scene."""
    why, pins = known
    short = gate.name[len(prefix) + 2:]
    if short not in pins:
        return gate
    pinned, (low, high) = pins[short]
    band = [low * pinned, high * pinned]
    ok = gate.value is not None and band[0] <= gate.value <= band[1]
    return Gate(f"{gate.name} (known limit)", ok, gate.value, band, gate.unit,
                f"{gate.description}; known limit above the {gate.threshold} {gate.unit} bound, pinned at {pinned}: "
                f"{why}. Fails if the figure leaves the band.", bound=gate.threshold)


def _le(value, limit) -> bool:
    """value <= limit, False for NaN or None (a figure that could not be measured fails)."""
    return value is not None and not (isinstance(value, float) and math.isnan(value)) and value <= limit


def _num(value, scale=1.0, fmt=".3g") -> str:
    return "n/a" if value is None or (isinstance(value, float) and math.isnan(value)) else format(value * scale, fmt)


def _row(s: dict, name: str, f: dict) -> tuple:
    shown = SENSITIVITY_LABEL if name == SENSITIVITY_CHECK else \
        sources.label(name) + ("" if name in PREDICTORS else " (reported, not gated)")
    return (s["scene"], shown, _num(f["simulated_s_learned"], fmt="g"), "yes" if f["diverged"] else "no",
            _num(f["final_position_error_max_m"], 1e3), _num(f["final_angle_error_max_deg"]),
            _num(f["max_penetration_m"], 1e3), f"{_num(f['energy_gain_gated_J'])} ({_num(s['energy_limit_J'])})",
            _drift(s, f),
            _num(f["leaves_truth_at_s"], fmt="g") if f["leaves_truth_at_s"] is not None else "never",
            _num(f["wall_per_sim_s_learned"], 1e3), _num(f["speedup_vs_truth"], fmt=".2f"),
            _num(f["speedup_vs_point"], fmt=".2f"),
            f"{_num(f.get('final_tilt_max_deg'))} ({_num(f.get('final_tilt_max_truth_deg'))})")


def _drift(s: dict, f: dict) -> str:
    if not s["resting"]:
        return "-"
    value = _num(f["drift_m_per_min_learned"], 1e3)
    return value if s["duration_s"] >= MIN_DRIFT_DURATION_S else f"{value} (settling; not judged)"


def _range(values, fmt=".2g") -> str:
    low, high = min(values), max(values)
    return format(low, fmt) if format(low, fmt) == format(high, fmt) else f"{format(low, fmt)}-{format(high, fmt)}"


def verdict(s: dict) -> str:
    """One line per scene: can the improved predictor drive it, how fast; what the paper MLP does."""
    parts = []
    for name, f in s["predictors"].items():
        if f["diverged"]:
            error = f["learned_error"]
            if error:
                when = f"fails at t = {f['simulated_s_learned']:g} s ({error[:70]}{'...' if len(error) > 70 else ''})"
            else:
                when = (f"max penetration {_num(f['max_penetration_m'], 1e3)} mm, "
                        f"energy created {_num(f['energy_gain_gated_J'])} J")
            left = f["leaves_truth_at_s"]
            parts.append(f"{sources.label(name)} diverges" + (f", leaves the truth by 2 cm at t = {left:g} s" if left is not None else "")
                         + f"; {when}")
            continue
        ok = ClosedLoopCase().gates({"id": "", "result": {**s, "predictors": {GATED: f}}})
        bad = [g.name.split(": ")[-1] for g in ok if not g.passed]
        what = f"{sources.label(name)} can drive it" if not bad else f"{sources.label(name)} runs but misses: {', '.join(bad)}"
        speeds = f"{_speed(f['speedup_vs_truth'], 'hydroelastic')}, {_speed(f['speedup_vs_point'], 'point')}"
        parts.append(f"{what}: {speeds}{_where_time_goes(f)}")
    return f"{s['scene']}: " + "; ".join(parts)


def _where_time_goes(f: dict) -> str:
    """Where the learned run's wall time went, when it is not faster than the truth ('' else)."""

    ratio = f.get("speedup_vs_truth")
    line = breakdown_line(f.get("cost_learned"))
    if line is None or ratio is None or ratio >= 1:
        return ""
    return f" (its wall time: {line})"


def _speed(ratio, against: str) -> str:
    """'2.1x faster than X' or '1.5x slower than X' from ratio = wall(X) / wall(learned)."""
    if ratio is None or not ratio > 0:
        return f"speed vs {against} n/a"
    return f"{ratio:.2g}x faster than {against}" if ratio >= 1 else f"{1 / ratio:.2g}x slower than {against}"
