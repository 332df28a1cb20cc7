"""Case kind `truth_ladder`: how far the ground truth itself is from a converged answer
(testbed.studies.truth), and a gate that no closed-loop bound lies below it.

The default suite runs a quick ladder (QUICK: two scenes, the shipped discrete plant, Drake's
triangle representation and the continuous-time plant at two accuracies); --suite full runs the
study's whole ladder on its scenes. Per scene and closed-loop gate quantity (final position of
each free container, final angle, max penetration) the truth's own uncertainty is the one of the
reference the scene is judged against (scenario.truth): the continuous rung's accuracy sequence
where the scene says `truth: {reference: continuous}`, else the discrete plant's distance from the
ladder's finest rung (at least the reference's band). Gate: that uncertainty <= the closed-loop
bound on the quantity (testbed/gates/closed_loop.py), so a scene whose discrete truth is
mesh-sensitive beyond a bound fails until it is judged against the converged rung.
"""

from __future__ import annotations

import math

from testbed.document import Section, Text, table
from testbed.gates import Gate
from testbed.gates.closed_loop import FINAL_ANGLE_TOL_DEG, FINAL_POSITION_TOL_M, MAX_PENETRATION_M
from testbed.scenario import load_scenario
from testbed.studies.truth.run import FULL_SCENES, load_scenes, run_loaded
from testbed.studies.truth.rungs import DEFAULT_ACCURACIES, RUNGS
from testbed.validation.cases import Case, CaseKind, register

# (scene, duration [s]): overhang_tip over its whole tip (the discrete plant is 0.75 deg from the
# converged one there); two_stack long enough to settle its offset load
QUICK = (("overhang_tip", 0.9), ("two_stack", 0.3))
QUICK_RUNGS = ("polygon", "triangle", "continuous")
QUICK_ACCURACIES = (1e-2, 1e-3)


def _bounds():
    return {"final position": (FINAL_POSITION_TOL_M, "m"), "final angle": (FINAL_ANGLE_TOL_DEG, "deg"),
            "max penetration": (MAX_PENETRATION_M, "m")}


def _uncertainty(entry: dict, continuous: bool) -> float:
    """The truth's own uncertainty on one quantity for the reference the scene uses."""
    if entry is None:
        return float("nan")
    if continuous:
        u = entry.get("reference_uncertainty")
        return max(u if u is not None else float("nan"), entry.get("resolution") or 0.0)
    u = entry.get("uncertainty")
    return float("nan") if u is None else float(u)


def scene_uncertainties(scene: dict, continuous: bool) -> dict:
    """{gate quantity: truth uncertainty} of one scene's ladder result: final position (the norm
    over x, y, z of the worst container), final angle (the worst container), max penetration."""
    q = scene["quantities"]
    containers = sorted({name.split(".")[0] for name in q if name.endswith(".final_angle_deg")})
    position = max((math.sqrt(sum(_uncertainty(q.get(f"{c}.final_{a}_m"), continuous) ** 2 for a in "xyz"))
                    for c in containers), default=float("nan"))
    angle = max((_uncertainty(q.get(f"{c}.final_angle_deg"), continuous) for c in containers), default=float("nan"))
    return {"final position": position, "final angle": angle,
            "max penetration": _uncertainty(q.get("max_penetration_m"), continuous)}


@register
class TruthLadderCase(CaseKind):
    name = "truth_ladder"
    order = 47
    timing_keys = ("wall_s", "build_s", "wall_per_sim_s")

    def cases(self, suite: str) -> list[Case]:
        if suite == "default":
            return [Case("truth-ladder", self.name, {"quick": True})]
        if suite == "full":
            return [Case("truth-ladder", self.name, {"quick": False})]
        return []

    def run(self, quick: bool) -> dict:
        import tempfile

        with tempfile.TemporaryDirectory() as tmp:
            if quick:
                scenes = [s for name, d in QUICK for s in load_scenes([name], d, False)]
                study = run_loaded(scenes, rungs=QUICK_RUNGS, accuracies=QUICK_ACCURACIES, quick=True, cache_dir=tmp)
            else:
                study = run_loaded(load_scenes(FULL_SCENES, None, False), rungs=RUNGS, accuracies=DEFAULT_ACCURACIES,
                                   cache_dir=tmp)
        for scene in study["scenes"]:
            spec = load_scenario(scene["scene"]).truth
            scene["judged_against"] = spec.reference
            scene["gate_uncertainties"] = scene_uncertainties(scene, spec.reference == "continuous")
        return study

    def quick(self, records: list[dict]) -> str | None:
        if any(r["params"].get("quick") for r in records):
            return f"the truth ladder ({', '.join(n for n, _ in QUICK)}; --suite full or `testbed study truth` for all)"
        return None

    def gates(self, record: dict) -> list[Gate]:
        out = []
        for scene in record["result"]["scenes"]:
            against = scene["judged_against"]
            for quantity, (bound, unit) in _bounds().items():
                u = scene["gate_uncertainties"][quantity]
                out.append(Gate(
                    f"truth ladder: {scene['scene']}: the truth's own uncertainty on the {quantity}",
                    bool(u <= bound), u, bound, unit,
                    f"the {against} truth's uncertainty on the closed-loop {quantity} of {scene['scene']} "
                    f"({scene['duration_s']:g} s; ladder reference {scene['reference_rung']}; "
                    f"{scene['classification']}) must not exceed the gate's bound", uncertainty=u))
        return out

    def sections(self, records: list[dict]) -> list[Section]:
        if not records:
            return []
        rows = []
        for s in records[0]["result"]["scenes"]:
            walls = {n: r["wall_per_sim_s"] for n, r in s["rungs"].items()}
            u = s["gate_uncertainties"]
            rows.append((s["scene"], s["classification"], s["judged_against"], s["reference_rung"],
                         f"{u['final position'] * 1e3:.3g}", f"{u['final angle']:.3g}", f"{u['max penetration'] * 1e3:.3g}",
                         ", ".join(f"{n} {w:.2f}" if w is not None else f"{n} failed" for n, w in walls.items())))
        return [Section("The truth's own accuracy (truth ladder)", [
            Text("Each scene under a ladder of ground truths: Drake's discrete plant as shipped (one point per contact "
                 "polygon), the triangle representation, and the continuous-time plant (exact moments) at two "
                 "accuracies. A scene is converged when the discrete answer lies within the finest rung's uncertainty "
                 "on every quantity; a truth-sensitive scene is judged against the continuous rung (its YAML's "
                 "`truth:`). Uncertainties are of the truth each scene is judged against, in mm and deg; wall time "
                 "per simulated second in s. The whole ladder: `testbed study truth` (docs/truth.md)."),
            table(["scene", "classification", "judged against", "ladder reference", "final position [mm]",
                   "final angle [deg]", "max penetration [mm]", "wall per simulated s per rung [s]"], rows)],
            order=48)]
