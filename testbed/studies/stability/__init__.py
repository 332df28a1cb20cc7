"""The `stability` study: the stability matrix (hard cases x contact model x discrete
approximation x time step), each entry judged by the stress suite's criteria (matrix.py).

`from testbed.studies.stability import matrix_cases, check, ...` keeps working: the names of
matrix.py are read from it on first use (this `__init__` stays light for the CLI's parser).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

from testbed.document import Section, table, to_markdown
from testbed.progress import progress
from testbed.records import write_atomic
from testbed.studies import register
from testbed.studies.base import Study


@dataclasses.dataclass
class StabilityConfig:
    """quick: the small grid (matrix.matrix_cases); progress: a progress bar."""

    quick: bool = False
    progress: bool = True


def _code():
    """matrix.py, imported on first use (it imports pydrake)."""
    from testbed.studies.stability import matrix

    return matrix


@register
class StabilityStudy(Study):
    name = "stability"
    help = "the stability matrix: hard cases x contact model x approximation x time step, each judged stable or not"
    order = 30
    Config = StabilityConfig

    def configure(self, args) -> StabilityConfig:
        return StabilityConfig(quick=bool(args.quick), progress=not args.quiet)

    def run(self, config: StabilityConfig, out: Path, map_calls=None) -> list[dict]:
        matrix = _code()
        grid = matrix.matrix_cases(quick=config.quick)
        if config.progress:
            grid = progress(grid, desc="stability matrix")
        return [matrix.run_matrix_entry(name, kw) for name, kw in grid]

    def report(self, rows: list[dict], out: Path) -> list[Path]:
        """stability.json (the rows) and stability.md (the matrix)."""
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        columns, grid = _code().stability_matrix(rows)
        return [write_atomic(out / "stability.json", json.dumps(rows, indent=1, default=float)),
                write_atomic(out / "stability.md", to_markdown("Stability matrix", [Section(None, [table(["case", *columns], grid)])]))]

    def summary(self, rows: list[dict]) -> list[str]:
        lines = [f"UNSTABLE {r['case']} / {r['model']} / {r['approximation']} / h={r['time_step']:g}: {r['failed']}"
                 for r in rows if not r["stable"]]
        return lines + [f"{sum(r['stable'] for r in rows)} of {len(rows)} stable"]


def __getattr__(name):
    if name.startswith("__") or name == "matrix":  # the submodule itself: imported, not forwarded
        raise AttributeError(name)
    return getattr(_code(), name)
