"""Case kind `scale`: what a yard of N containers costs with each contact model, at a few
small sizes (testbed.studies.scale; the whole curve is `testbed study scale`). One case per
(size, model) cell, so the executor spreads them like any other case; the section is the
study's own report (its growth exponents over the sizes run here: indicative, the sizes
are small). Reported, not gated: wall times on a shared machine are ratios within one run.
"""

from __future__ import annotations

import dataclasses

from testbed.studies.scale import ScaleConfig, growth_fits, report_sections, run_cell, tasks, with_errors
from testbed.validation.cases import Case, CaseKind, register

# The validation's size range: three yards whose cells cost ~40 s of worker time together on
# 2 shared cores (the 48-container hydroelastic run is most of it), 0.05 s simulated each.
VALIDATE = ScaleConfig(sizes=(4, 16, 48), duration=0.05, big_duration=0.05, fit_from=4, repeats=1)
SMOKE = ScaleConfig(sizes=(4, 8), duration=0.02, big_duration=0.02, fit_from=4, repeats=1)


@register
class ScaleCase(CaseKind):
    name = "scale"
    order = 35
    timing_keys = ("wall_per_sim_s", "real_time_factor", "us_per_step", "split_us")

    def cases(self, suite: str) -> list[Case]:
        config = {"default": VALIDATE, "full": VALIDATE}.get(suite)  # smoke: none (it stays seconds long)
        if config is None:
            return []
        return [Case(f"scale-{t['n']}-{t['model']}", self.name, {"task": t}) for t in tasks(config)]

    def run(self, task: dict) -> dict:
        return run_cell(task)

    def quick(self, records: list[dict]) -> str | None:
        sizes = sorted({r["result"]["n"] for r in records})
        return f"the yard-size study at N = {', '.join(map(str, sizes))} (`testbed study scale` runs 4 to 192)" if sizes else None

    def sections(self, records: list[dict]) -> list:
        if not records:
            return []
        config = records[0]["params"]["task"]["config"]
        rows = with_errors(sorted((r["result"] for r in records), key=lambda row: (row["n"], config["models"].index(row["model"]))))
        study = {"config": config, "rows": rows, "fits": growth_fits(rows, config["models"], config["fit_from"]),
                 "executor": "validate's executor", "wall_s": sum(r.get("wall_s", 0.0) for r in records),
                 "environment": {"cpus": "-", "drake": "-", "engines": {}}}
        return [dataclasses.replace(section, order=32 + i)  # the summary, the targets, the chart
                for i, section in enumerate(report_sections(study)[:3])]
