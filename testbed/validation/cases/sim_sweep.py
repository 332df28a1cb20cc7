"""Case kind `sim_sweep`: whole simulations, cost against accuracy (testbed.studies.sim).

Section: the cost/accuracy chart (one curve per contact configuration) and its table."""

from __future__ import annotations

import math

from testbed.document import Figure, Section, png, pyplot, table
from testbed.validation.cases import Case, CaseKind, register


def _case(scene, model, approximation, time_steps, duration, reference_step=1e-4) -> Case:
    """One configuration; time_steps and reference_step [s], duration [s] simulated."""
    return Case(f"sim-{scene}-{model}-{approximation}", "sim_sweep", {
        "scene": scene, "models": [model], "approximations": [approximation], "time_steps": time_steps,
        "reference_step": reference_step, "duration": duration})


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
                    for m in ("hydroelastic", "point") for a in ("sap", "tamsi")]
        if suite == "full":
            return [_case(s, m, a, [2e-4, 5e-4, 1e-3, 2e-3, 5e-3, 1e-2], 1.0) for s in ("two_stack", "five_stack")
                    for m in ("hydroelastic", "point") for a in ("sap", "tamsi", "similar", "lagged")]
        return []

    def run(self, scene, models, approximations, time_steps, reference_step, duration) -> dict:
        from testbed.studies.sim import sweep

        return {"rows": sweep(scene, models=models, approximations=approximations, time_steps=time_steps,
                              reference_step=reference_step, duration=duration)}

    def sections(self, records: list[dict]) -> list[Section]:
        rows = [row for r in records for row in r["result"]["rows"]]
        if not rows:
            return []
        return [Section("Simulation study: what accuracy costs in time (whole simulations)", [
            Figure("figures/sim.png", "simulation cost vs accuracy", _chart(rows)),
            table(["scene", "model", "approximation", "time step [s]", "ms / sim s", "deviation [mm]",
                   "max penetration [mm]", "energy gain [J]", "status"],
                  [(r["scene"], r["model"], r["approximation"], f"{r['time_step']:g}", f"{r['ms_per_sim_second']:.0f}",
                    f"{r['deviation_m'] * 1e3:.3f}", f"{r['max_penetration_m'] * 1e3:.2f}", f"{r['energy_gain_J']:.1f}",
                    r["status"]) for r in rows]),
        ], order=20)]


def _chart(rows) -> bytes:
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    curves = {}
    for r in rows:
        curves.setdefault((r["scene"], r["model"], r["approximation"]), []).append(r)
    for (scene, model, approximation), points in sorted(curves.items()):
        points = [p for p in points if p["status"] == "ok" and math.isfinite(p["deviation_m"])]
        points.sort(key=lambda p: p["ms_per_sim_second"])
        if points:
            ax.plot([p["ms_per_sim_second"] for p in points], [max(p["deviation_m"], 1e-9) for p in points],
                    "o-", label=f"{scene} {model} {approximation}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("wall time per simulated second [ms]")
    ax.set_ylabel("RMS deviation from the reference step [m]")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    ax.set_title("Simulation cost vs accuracy (one curve per contact configuration)")
    return png(fig)
