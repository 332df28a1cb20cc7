"""Case kind `scale`: what a yard of N containers costs with each contact model, at a few
small sizes (testbed.studies.scale; the whole curve is `testbed study scale`). One case per
(size, model) cell of the settled yard, so the executor spreads them like any other case; the
section is the study's own report (its growth exponents over the sizes run here: indicative,
the sizes are small). Reported, not gated: wall times on a shared machine are ratios within one run.
"""

from __future__ import annotations

import dataclasses

from testbed.studies.scale.cells import run_cell, tasks, with_errors
from testbed.studies.scale.fit import pass_fits, yard_fits
from testbed.studies.scale.report import report_sections
from testbed.studies.scale.settings import ScaleConfig, from_dict
from testbed.validation.cases import Case, CaseKind, register

# The validation's size range: three settled yards, each settling 0.02 s untimed before a 0.05 s
# timed window, one pass, no size caps; the 48-container hydroelastic run is most of their cost.
VALIDATE = ScaleConfig(sizes=(4, 16, 48), settle_s=0.02, duration=0.05, big_duration=0.05, yards=("settled",), caps=(),
                       fit_from=4, passes=1, repeats=1)
SMOKE = ScaleConfig(sizes=(4, 8), settle_s=0.01, duration=0.02, big_duration=0.02, yards=("settled",), caps=(),
                    fit_from=4, passes=1, repeats=1)
SECTIONS = ("What a yard of N containers costs", "Targets", "Cost per step against N")  # of the study's report


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
        return f"the yard-size study at N = {', '.join(map(str, sizes))} (`testbed study scale` runs 96 to 1000)" if sizes else None

    def sections(self, records: list[dict]) -> list:
        if not records:
            return []
        config = from_dict(records[0]["params"]["task"]["config"])
        names = config.model_names()
        rows = with_errors(sorted((r["result"] for r in records),
                                  key=lambda row: (row["n"], names.index(row["model"]) if row["model"] in names else len(names))))
        study = {"config": dataclasses.asdict(config), "rows": rows,
                 "fits": yard_fits(rows, names, config.fit_from, config.yards),
                 "pass_fits": pass_fits(rows, names, config.fit_from, config.yards, config.passes),
                 "executor": "validate's executor", "wall_s": sum(r.get("wall_s", 0.0) for r in records),
                 "environment": {"cpus": "-", "drake": "-", "engines": {}}}
        chosen = [s for s in report_sections(study) if s.title in SECTIONS]
        return [dataclasses.replace(section, order=32 + i) for i, section in enumerate(chosen)]
