"""Case kind `effect_costs`: what each effect costs in wall time (testbed.studies.sim).

Runs in the main process, alone: it measures Meshcat (which must not start in a worker)
and time ratios that parallel cases would disturb. Section: a bar chart and a list."""

from __future__ import annotations

from testbed.document import Bullets, Figure, Section, png, pyplot
from testbed.studies.sim import effect_costs
from testbed.validation.cases import Case, CaseKind, register


@register
class EffectCostsCase(CaseKind):
    name = "effect_costs"
    order = 30
    main_process = True
    timing_keys = ("ratio",)

    def cases(self, suite: str) -> list[Case]:
        if suite == "default":
            return [Case("effect-costs-five_stack", "effect_costs", {"scene": "five_stack", "duration": 0.3})]
        if suite == "full":
            return [Case(f"effect-costs-{s}", "effect_costs", {"scene": s, "duration": 1.0})
                    for s in ("two_stack", "five_stack")]
        return []

    def run(self, scene: str, duration: float) -> dict:
        return {"scene": scene, "rows": effect_costs(scene, duration=duration)}

    def sections(self, records: list[dict]) -> list[Section]:
        rows = [(r["result"]["scene"], row) for r in records for row in r["result"]["rows"]]
        if not rows:
            return []
        items = [f"{scene}: {row['effect']}: " + (f"{row['ratio']:.2f}x" if row.get("status") == "ok" else str(row.get("status")))
                 for scene, row in rows]
        blocks = [Bullets(tuple(items))]
        measured = [(scene, row) for scene, row in rows if row.get("status") == "ok"]
        if measured:
            blocks.insert(0, Figure("figures/effects.png", "effect costs", _chart(measured)))
        return [Section("What each effect costs (wall time with the effect / bare)", blocks, order=50)]


def _chart(rows) -> bytes:
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 3.2))
    ax.bar([f"{scene}\n{row['effect']}" for scene, row in rows], [row["ratio"] for _, row in rows], color="#4a7ab5")
    ax.axhline(1.0, color="k", lw=0.8)
    ax.set_ylabel("wall time / bare scene")
    ax.set_title("What each effect costs")
    ax.tick_params(axis="x", labelsize=7)
    return png(fig)
