"""Case kind `sim_sweep`: whole simulations, cost against accuracy (testbed.studies.sim).

A case may ask for other engines' curves beside Drake's (`engines: ["drake", <engine names>]`;
engine_cases asks for every registered engine with contact of its own: testbed/engines): the
same time-step sweep simulated by that engine with each of its contact parameter sets, its
error measured against the fine-step Drake reference of the scene's own contact model.
Section: the cost/accuracy chart (one curve per engine and contact configuration, Drake
solid, the other engines dashed) and its table."""

from __future__ import annotations

import math

from testbed.document import Figure, Section, Text, png, pyplot, table
from testbed.drake_support import available
from testbed.engines import alternatives, engine as registered
from testbed.studies.sim import sweep
from testbed.validation.cases import Case, CaseKind, register
from testbed.validation.cases.engine import SECTION_ORDER

SCENE_MODEL = "hydroelastic_with_fallback"  # the shipped scenes' own contact model (their ground truth)
# Time steps of the engine sweeps: each divides the 10 ms sample period, so both engines
# sample the same instants (Drake's reference included).
ENGINE_STEPS = [5e-4, 1e-3, 2e-3, 5e-3, 1e-2]
# (scene, simulated duration [s]): a resting stack, the nine-high stack, a drop (lands at
# ~0.25 s, settles by 1 s) and a slide to rest (stops at ~0.8 s).
ENGINE_SCENES = (("two_stack", 0.5), ("nine_mixed_stack", 0.5), ("single_drop", 1.0), ("quay_slide_to_rest", 1.2))


def _case(scene, model, approximation, time_steps, duration, reference_step=1e-4, engines=("drake",)) -> Case:
    """One configuration; time_steps and reference_step [s], duration [s] simulated."""
    suffix = "".join(f"-{e}" for e in engines if e != "drake")
    return Case(f"sim-{scene}-{model}-{approximation}{suffix}", "sim_sweep", {
        "scene": scene, "models": [model], "approximations": [approximation], "time_steps": time_steps,
        "reference_step": reference_step, "duration": duration, "engines": list(engines)})


def engine_cases(scenes=ENGINE_SCENES, time_steps=ENGINE_STEPS) -> list[Case]:
    """Drake (the scene's own model, SAP) and every other engine (testbed.engines.alternatives)
    over one time-step sweep, per scene."""
    engines = ("drake", *(e.name for e in alternatives()))
    return [_case(s, SCENE_MODEL, "sap", time_steps, d, engines=engines) for s, d in scenes]


@register
class SimSweepCase(CaseKind):
    name = "sim_sweep"
    order = 20
    timing_keys = ("ms_per_sim_second",)

    def cases(self, suite: str) -> list[Case]:
        if suite == "smoke":
            return [_case("two_stack", "point", "sap", [2e-3, 5e-3], 0.05, reference_step=1e-3)]
        if suite == "default":
            return [_case("two_stack", m, a, [3e-4, 1e-3, 3e-3, 1e-2], 0.5)
                    for m in ("hydroelastic", "point") for a in available(("sap", "tamsi"))] + engine_cases()
        if suite == "full":
            return [_case(s, m, a, [2e-4, 5e-4, 1e-3, 2e-3, 5e-3, 1e-2], 1.0) for s in ("two_stack", "five_stack")
                    for m in ("hydroelastic", "point") for a in available(("sap", "tamsi", "similar", "lagged"))] + \
                engine_cases(ENGINE_SCENES + (("five_stack", 1.0), ("bridge", 1.0)), [2e-4] + ENGINE_STEPS)
        return []

    def run(self, scene, models, approximations, time_steps, reference_step, duration, engines=("drake",)) -> dict:
        return {"rows": sweep(scene, models=models, approximations=approximations, time_steps=time_steps,
                              reference_step=reference_step, duration=duration, engines=tuple(engines))}

    def sections(self, records: list[dict]) -> list[Section]:
        rows = [row for r in records for row in r["result"]["rows"]]
        if not rows:
            return []
        engine_rows = [row for r in records if _other_engines(r) for row in r["result"]["rows"]]
        # the Drake configurations on this section's chart; the engine sweeps (Drake and the others)
        # on their own chart in the engine section (below), when there are both kinds of case
        drake_rows = [row for r in records if not _other_engines(r) for row in r["result"]["rows"]]
        blocks = [Figure("figures/sim.png", "simulation cost vs accuracy", chart(drake_rows or rows))]
        if engine_rows:
            blocks.insert(0, Text(ENGINE_NOTE))
        blocks.append(table(["scene", "engine", "model", "approximation / parameters", "time step [s]", "ms / sim s",
                             "deviation [mm]", "max penetration [mm]", "energy gain [J]", "status"],
                            [(r["scene"], r.get("engine", "drake"), r["model"], r["approximation"], f"{r['time_step']:g}",
                              f"{r['ms_per_sim_second']:.1f}", f"{r['deviation_m'] * 1e3:.3f}",
                              f"{r['max_penetration_m'] * 1e3:.2f}", f"{r['energy_gain_J']:.1f}", r["status"])
                             for r in rows]))
        out = [Section("Simulation study: what accuracy costs in time (whole simulations)", blocks, order=20)]
        if engine_rows:
            out.append(engine_chart_section(engine_rows))
        return out


def _other_engines(record) -> bool:
    """Whether a case swept an engine besides Drake."""
    return any(e != "drake" for e in record["params"].get("engines", ()))


def engine_chart_section(rows) -> Section:
    """The speed-accuracy chart of the engine sweeps (Drake and every other engine on one chart), placed
    right after the engine kind's section "The engine users would pick instead" (untitled,
    so it reads as that section's chart)."""
    scenes = sorted({r["scene"] for r in rows})
    names = [e.label for e in alternatives() if any(r.get("engine") == e.name for r in rows)]
    others = " and ".join(names) or "the other engines"
    return Section(None, [
        Text(f"Speed against accuracy, Drake and {others} over one time-step sweep ({', '.join(scenes)}): error is the RMS "
             "position deviation from Drake's run of the scene's own contact model at the reference step (the same "
             "figures as the simulation study's table)."),
        Figure("figures/engine_speed_accuracy.png", f"{others} and Drake: error vs wall time per simulated second",
               chart(rows, title=f"Drake (solid) vs {others} (dashed, dotted per parameter set); one colour per scene")),
    ], order=SECTION_ORDER + 1)


ENGINE_NOTE = ("Drake rows: deviation from the same model's run at the reference step. Every other engine's rows (charted "
               "with the same scenes' Drake sweeps under 'The engine users would pick instead', one curve per parameter "
               "set): deviation from Drake's run of the scene's own contact model at the reference step, i.e. from the "
               "ground truth, so an engine's curve levels off at its modelling difference.")


STYLES = ("s--", "^:", "d-.", "v--")  # an engine's parameter sets, in its param_sets order; Drake curves are "o-"


def chart(rows, title="Simulation cost vs accuracy (one curve per engine and contact configuration)") -> bytes:
    """Deviation [m] against wall time per simulated second [ms], log-log, one curve per
    (scene, engine, model, approximation), its points in time-step order (coarsest first);
    one colour per scene when the rows span several scenes, else one per curve; PNG bytes."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7.0, 4.6))
    curves = {}
    for r in rows:
        curves.setdefault((r["scene"], r.get("engine", "drake"), r["model"], r["approximation"]), []).append(r)
    scenes = sorted({key[0] for key in curves})
    cycle = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, ((scene, engine, model, approximation), points) in enumerate(sorted(curves.items())):
        points = [p for p in points if p["status"] == "ok" and math.isfinite(p["deviation_m"])]
        points.sort(key=lambda p: -p["time_step"])
        if not points:
            continue
        colour = cycle[(scenes.index(scene) if len(scenes) > 1 else i) % len(cycle)]
        if engine != "drake":
            sets = registered(engine).param_sets
            style = STYLES[sets.index(approximation) % len(STYLES)] if approximation in sets else STYLES[0]
            label = f"{scene} {registered(engine).label} {approximation}"
        else:
            label, style = f"{scene} Drake {model} {approximation}", "o-"
        ax.plot([p["ms_per_sim_second"] for p in points], [max(p["deviation_m"], 1e-9) for p in points], style,
                color=colour, label=label)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("wall time per simulated second [ms]")
    ax.set_ylabel("RMS deviation from the reference [m]")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=6, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.set_title(title, fontsize=9)
    return png(fig)
