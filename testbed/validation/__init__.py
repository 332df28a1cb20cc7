"""`testbed validate`: a suite of cases run in worker processes, one report.

  suites.py      named suites (each case kind lists its cases per suite)
  cases/         the case kinds, one module each (registry): how a case runs, which
                 gates it judges, which report sections it contributes
  executors.py   local process pool and Ray; results written as they arrive
  gates.py       typed Gate verdicts
  replays.py     Meshcat replays of the worst learned cases
  report.py      metrics.json, summary.md, index.html (rendered by testbed.document)
  run.py         validate(): run or resume a suite, then the report

A killed run loses nothing: `--resume <run>` recomputes only the missing cases and
rebuilds the report from the case files.
"""

from testbed.validation.cases import Case
from testbed.validation.report import SCHEMA_VERSION, is_timing_key
from testbed.validation.run import validate

__all__ = ["Case", "SCHEMA_VERSION", "is_timing_key", "validate"]
