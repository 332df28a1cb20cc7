"""The scale study's whole grid: every cell (cells.py), the errors against the reference and
the growth fits (fit.py), as one JSON-able record."""

from __future__ import annotations

import dataclasses
import os
import platform
import time

from testbed.drake_support import drake_version
from testbed.progress import progress as progress_bar
from testbed.studies.scale.cells import run_cell, tasks, with_errors
from testbed.studies.scale.fit import pass_fits, yard_fits
from testbed.studies.scale.settings import CLOCKS, ScaleConfig

SCHEMA = "testbed.study.scale/2"


def run_study(config: ScaleConfig, *, map_cells=None, progress: bool = False, executor: str = "sequential") -> dict:
    """Runs every cell and returns the study's record (JSON-able): {'schema', 'config', 'rows'
    (run_cell's, with errors: with_errors), 'fits' (yard_fits: per yard kind and model, every pass pooled), 'pass_fits'
    (pass_fits: one fit per pass, model and yard), 'environment', 'executor', 'wall_s'}.

    map_cells: None runs the cells here one after the other; else a callable
    (fn, items, done) that calls done(fn(item)) for every item, in any order (e.g.
    testbed.validation.executors.map_calls), named by `executor` in the report."""
    config.validate()
    start = time.perf_counter()
    todo, results = tasks(config), []
    if map_cells is None:
        cells = progress_bar(todo, desc="scale study", unit="cell") if progress else todo
        results = [run_cell(t) for t in cells]
    else:
        map_cells(run_cell, todo, results.append)
    return assemble(config, results, todo, executor, time.perf_counter() - start)


def assemble(config: ScaleConfig, results: list[dict], todo: list[dict], executor: str, wall_s: float) -> dict:
    """The study's record from its cells' rows (any order)."""
    order = {(t["pass"], t["n"], t["model"], t["yard"]): i for i, t in enumerate(todo)}
    rows = with_errors(sorted(results, key=lambda r: order[r["pass"], r["n"], r["model"], r["yard"]]))
    versions = {r["engine"]: r["version"] for r in rows if r.get("version")}
    models, key = config.model_names(), CLOCKS[config.clock][0]
    return {"schema": SCHEMA, "config": dataclasses.asdict(config), "rows": rows,
            "fits": yard_fits(rows, models, config.fit_from, config.yards, key),
            "pass_fits": pass_fits(rows, models, config.fit_from, config.yards, config.passes, key),
            "environment": {"python": platform.python_version(), "machine": platform.machine(), "cpus": os.cpu_count(),
                            "drake": drake_version(), "engines": versions},
            "executor": executor, "wall_s": wall_s}
