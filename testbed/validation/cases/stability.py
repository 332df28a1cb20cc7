"""Case kind `stability`: the stability matrix (testbed.studies.stability), split into
cases of PER_CASE grid entries. Section: the unstable entries (brief) and the matrix."""

from __future__ import annotations

from testbed.document import Bullets, Section, Text, table
from testbed.studies.stability import matrix_cases, run_matrix_entry, stability_matrix
from testbed.validation.cases import Case, CaseKind, register

PER_CASE = 6  # grid entries per case


def stability_cases(quick: bool, per_case: int = PER_CASE) -> list[Case]:
    """The stability matrix split into cases of `per_case` grid entries each."""
    grid = [[name, kw] for name, kw in matrix_cases(quick=quick)]
    return [Case(f"stability-{i // per_case:02d}", "stability", {"entries": grid[i:i + per_case]})
            for i in range(0, len(grid), per_case)]


@register
class StabilityCase(CaseKind):
    name = "stability"
    order = 60

    def cases(self, suite: str) -> list[Case]:
        return stability_cases(quick=suite == "default") if suite in ("default", "full") else []

    def run(self, entries) -> dict:
        return {"rows": [run_matrix_entry(name, kw) for name, kw in entries]}

    def quick(self, records: list[dict]) -> str | None:
        ran = sum(len(r["params"]["entries"]) for r in records)
        full = len(matrix_cases(quick=False))
        return f"the stability matrix ({ran} of the full matrix's {full} entries)" if records and ran < full else None

    def sections(self, records: list[dict]) -> list[Section]:
        rows = [row for r in records for row in r["result"]["rows"]]
        if not rows:
            return []
        unstable = [r for r in rows if not r["stable"]]
        columns, matrix = stability_matrix(rows)
        brief = [Bullets(tuple(f"{r['case']} / {r['model']} / {r['approximation']} / h = {r['time_step']:g} s: {r['failed']}"
                               for r in unstable)),
                 Text(f"{len(rows) - len(unstable)} of {len(rows)} grid entries stable.")]
        return [Section("Stability matrix (unstable entries)", brief, order=40),
                Section("Stability matrix", [
                    Text("Case x contact model / approximation / time step. A cell names the criterion that failed and "
                         "its figure (testbed/studies/stability/matrix.py states each criterion)."),
                    table(["case", *columns], matrix)], order=41, brief=False)]
