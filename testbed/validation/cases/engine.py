"""Case kind `engine`: the same scenes simulated by the other engines (testbed/engines: every
registered one but Drake and the gated learned loop), against Drake's ground truth.

One case per scene, one compare_candidates run per engine (testbed/compare/run_candidates.py):
Drake's run of the scene's own contact model (the ground truth, once, with its contact log; timed
again without it for its wall time), Drake point contact (for its speed) and the engine with each of
its parameter sets (Engine.param_sets) as the candidates, all in one process; each engine's own
words for the report are its Engine.report_note, so adding an engine touches its package only.
Drake runs the scene's own contact parameters (the shipped 1e9 Pa unless the scene overrides
them), not the learned twins' 1e8 Pa, unless the engine is a learned one. A missing engine, or
a scene it cannot translate, makes the case unavailable (a result saying why), not an error.
Reported, not gated.

Section "The engine users would pick instead": the table per scene and parameter set.
Its speed-accuracy chart comes from the simulation study's engine curves: the
`sim_sweep` kind places it right after this section (cases/sim_sweep.py: engine_chart_section, at SECTION_ORDER + 1).
"""

from __future__ import annotations

import math

from learned_contact import sources
from testbed.compare import Candidate, compare_candidates
from testbed.document import Section, Text, table
from testbed.engines import UnsupportedSceneError, alternatives
from testbed.scenario import load_scenario, resolve_scene_path
from testbed.validation.cases import Case, CaseKind, register

SECTION_ORDER = 30  # the sim_sweep kind's engine chart follows at SECTION_ORDER + 1
SECTION_TITLE = "The engine users would pick instead"
# (scene, simulated duration [s]): each scene's own, nine_mixed_stack cut from 5 s to 2 s
# (Drake's hydroelastic run of it costs ~7 s per simulated second here, three times over).
# Measured on 2 busy cores (load ~4.7): 132 s of worker time for all seven (crane_misaligned,
# 83 s alone, is in the full suite only).
DEFAULT_SCENES = (("two_stack", 2.0), ("five_stack", 2.0), ("nine_mixed_stack", 2.0), ("single_drop", 2.0),
                  ("bridge", 2.0), ("quay_slide_to_rest", 1.2), ("crane_hard_landing", 3.0))
FULL_EXTRA = (("crane_misaligned", 5.0), ("windy_stack", 4.0), ("crane_edge_landing", 5.0), ("crane_landing_sway", 9.0),
              ("quay_wind_slide", 1.0), ("stack_slide_off", 3.0))
SMOKE_DURATION_S = 0.3



def keys(name: str) -> tuple:
    """The figures kept per parameter set of engine `name` (scalars of compare.json and the
    contact comparison)."""
    return ("diverged", "position_error_max_m", "final_position_error_max_m", "final_angle_error_max_deg",
            "max_penetration_m", "energy_gain_max_J", "contact_point_error_median_m", "contact_point_error_p95_m",
            "contact_point_error_final_max_m", "contact_normal_error_max_deg", "contact_rows_compared",
            f"contact_rows_missing_{name}", f"wall_per_sim_s_{name}", "speedup_vs_hydroelastic", "speedup_vs_point",
            "simulated_s_learned")



def engine_table_row(scene: str, e, duration: float) -> dict:
    """One scene, Drake's truth run once, Drake point and engine `e` once per parameter set (as
    candidates of one compare_candidates run, contact rows compared):
    {'scene', 'duration_s', 'time_step_s', 'wall_per_sim_s_hydroelastic', 'wall_per_sim_s_point',
     e.name: {params: figures}}, figures with the engine's keys(e.name) and the speed-ups against
    Drake's hydroelastic and point runs. Raises UnsupportedSceneError."""
    sets = row_sets(e)
    chosen = [Candidate.point(), *(Candidate(e.name, predictor=p) if e.learned else Candidate(e.name, params=p)
                                   for p in sets)]
    f = compare_candidates(load_scenario(resolve_scene_path(scene)), chosen, duration=duration, contacts=True)
    point = f["candidates"]["Drake point"]
    row = {"scene": f["scene"], "duration_s": f["duration_s"], "time_step_s": f["time_step_s"],
           "wall_per_sim_s_hydroelastic": f["wall_per_sim_s_truth"],
           "wall_per_sim_s_point": point["wall_per_sim_s_learned"], e.name: {}}
    for c, p in zip(chosen[1:], sets):
        figures = f["candidates"][c.label]
        row[e.name][p] = {**figures, f"wall_per_sim_s_{e.name}": figures["wall_per_sim_s_learned"],
                          f"contact_rows_missing_{e.name}": figures.get("contact_rows_missing"),
                          "speedup_vs_hydroelastic": figures["speedup_vs_truth"]}
    return row


def row_sets(e) -> tuple:
    """What engine `e`'s rows are keyed by: the shipped predictor for an engine a predictor decides
    (its parameter), else its contact-parameter sets (None: it has none)."""
    return (sources.DEFAULT,) if e.learned else (e.param_sets or (None,))


def engine_cases(scenes) -> list[Case]:
    return [Case(f"engine-{s}", "engine", {"scene": s, "duration": d}) for s, d in scenes]


@register
class EngineCase(CaseKind):
    name = "engine"
    order = 30
    timing_keys = ("wall_per_sim_s_hydroelastic", "wall_per_sim_s_point",
                   "speedup_vs_hydroelastic", "speedup_vs_point")

    def cases(self, suite: str) -> list[Case]:
        if suite == "smoke":
            return engine_cases([("two_stack", SMOKE_DURATION_S)])
        if suite == "default":
            return engine_cases(DEFAULT_SCENES)
        if suite == "full":
            return engine_cases(DEFAULT_SCENES + FULL_EXTRA)
        return []

    def run(self, scene: str, duration: float) -> dict:
        """Every other engine's table row; unavailable (with the first reason) when none ran."""
        out, reasons = {"scene": scene}, []
        for e in alternatives():
            reason = e.unavailable()
            if reason is None:
                try:
                    row = engine_table_row(scene, e, duration)
                except UnsupportedSceneError as err:
                    reason = str(err).strip().splitlines()[0]
            if reason is not None:
                reasons.append(reason)
                continue
            out.update({k: v for k, v in row.items() if k != e.name and k not in out})  # Drake's figures: the first engine's run
            out.update({"available": True, f"{e.name}_version": e.version(),
                        e.name: {p: {k: f.get(k) for k in keys(e.name)} for p, f in row[e.name].items()}})
        if not out.get("available"):
            return {"scene": scene, "available": False, "reason": reasons[0] if reasons else "no other engine"}
        return out

    def sections(self, records: list[dict]) -> list[Section]:
        if not records:
            return []
        results = [r["result"] for r in records]
        ran = [s for s in results if s.get("available")]
        blocks = [Text("Each scene simulated by every other engine (testbed/engines) against Drake's run of the scene's "
                       "own contact model (the ground truth). Speed = Drake's wall time per simulated second / the "
                       "engine's, measured side by side in one process.")]
        blocks += [Text(e.report_note) for e in alternatives() if e.report_note and any(e.name in s for s in ran)]
        if ran:
            blocks.append(Text(summary(ran)))
            blocks.append(table(
                ["scene", "engine (parameters)", "ran to [s]", "wall / sim s [ms]", "x vs hydroelastic",
                 "x vs point", "position err max [mm]", "final position err [mm]", "final angle err [deg]",
                 "max penetration [mm]", "energy gain [J]", "contact point err median [mm]", "p95 [mm]",
                 "normal err max [deg]", "diverged"],
                [_row(s, e.name, f"{e.label} ({p})", f) for s in ran for e in alternatives()
                 for p, f in s.get(e.name, {}).items()]))
        missing = [s for s in results if not s.get("available")]
        if missing:
            blocks.append(Text("Unavailable: " + "; ".join(f"{s['scene']} ({s['reason']})" for s in missing)))
        return [Section(SECTION_TITLE, blocks, order=SECTION_ORDER)]


def _range(values, fmt=".0f") -> str:
    low, high = min(values), max(values)
    return format(low, fmt) if format(low, fmt) == format(high, fmt) else f"{format(low, fmt)}-{format(high, fmt)}"


def _num(value, scale=1.0, fmt=".3g") -> str:
    return "n/a" if value is None or (isinstance(value, float) and math.isnan(value)) else format(value * scale, fmt)


def _row(s: dict, name: str, params: str, f: dict) -> tuple:
    return (s["scene"], params, _num(f["simulated_s_learned"], fmt="g"), _num(f[f"wall_per_sim_s_{name}"], 1e3),
            _num(f["speedup_vs_hydroelastic"], fmt=".0f"), _num(f["speedup_vs_point"], fmt=".0f"),
            _num(f["position_error_max_m"], 1e3), _num(f["final_position_error_max_m"], 1e3),
            _num(f["final_angle_error_max_deg"]), _num(f["max_penetration_m"], 1e3), _num(f["energy_gain_max_J"]),
            _num(f.get("contact_point_error_median_m"), 1e3), _num(f.get("contact_point_error_p95_m"), 1e3),
            _num(f.get("contact_normal_error_max_deg")), "yes" if f["diverged"] else "no")


def summary(ran: list[dict]) -> str:
    """One paragraph: the speed-up range and the worst trajectory error per engine and parameter set."""
    parts = []
    for e in alternatives():
        for p in row_sets(e):
            figures = [(s["scene"], s[e.name][p]) for s in ran if p in s.get(e.name, {})]
            if not figures:
                continue
            hydro = [f["speedup_vs_hydroelastic"] for _, f in figures]
            point = [f["speedup_vs_point"] for _, f in figures]
            scene, worst = max(figures, key=lambda x: -1.0 if x[1]["position_error_max_m"] is None
                               else x[1]["position_error_max_m"])
            parts.append(f"{e.label} ({p}) runs {_range(hydro)}x faster than Drake hydroelastic and "
                         f"{_range(point)}x faster than Drake point contact; its largest trajectory error "
                         f"is {_num(worst['position_error_max_m'], 1e3)} mm ({scene})")
    diverged = [f"{s['scene']} ({p})" for s in ran for e in alternatives() for p, f in s.get(e.name, {}).items()
                if f["diverged"]]
    return "; ".join(parts) + "." + (f" Diverged: {', '.join(diverged)}." if diverged else "")
