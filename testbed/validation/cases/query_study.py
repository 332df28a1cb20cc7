"""Case kind `query_study`: time per contact query against accuracy (testbed.studies.query).

The result holds the study's metrics only; the Pareto chart is drawn from them when the
report is written. Section: the chart and the study's own sections."""

from __future__ import annotations

from testbed.document import Section
from testbed.studies.query import render, run_query_study
from testbed.validation.cases import Case, CaseKind, register


@register
class QueryStudyCase(CaseKind):
    name = "query_study"
    order = 40
    timing_keys = ("pareto", "markdown", "throughput_us_per_pair")

    def cases(self, suite: str) -> list[Case]:
        if suite in ("default", "full"):
            return [Case("query-study", "query_study", {"quick": suite == "default", "seed": 0})]
        return []

    def with_predictors(self, cases: list[Case], predictors: list[str]) -> list[Case]:
        """The study times the added predictors too (methods bench_<label>_single/_batched)."""
        return [Case(c.id, c.kind, {**c.params, "predictors": list(predictors)}) for c in cases]

    def run(self, quick: bool, seed: int, predictors=()) -> dict:
        import tempfile
        from pathlib import Path

        with tempfile.TemporaryDirectory() as tmp:
            return {"metrics": run_query_study(Path(tmp), quick=quick, seed=seed, progress=False,
                                               extra_predictors=tuple(predictors))}

    def quick(self, records: list[dict]) -> str | None:
        quick = [r for r in records if r["params"].get("quick")]
        if not quick:
            return None
        config = quick[0]["result"]["metrics"]["config"]
        return f"the query study ({config['n_poses']} poses per set, {config['repeats']} timed repeats; --suite full for the full study)"

    def sections(self, records: list[dict]) -> list[Section]:
        if not records:
            return []

        metrics = records[0]["result"]["metrics"]
        chart = render.chart_png(metrics)
        study = render.sections(metrics, chart, level=3, order=11, chart_file=f"figures/{render.CHART_FILE}")
        return [Section("Query study: what accuracy costs in time (per query)", [], order=10), *study]
