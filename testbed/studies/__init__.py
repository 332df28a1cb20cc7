"""Cost/accuracy studies of the testbed ("what does accuracy cost in time").

- query: time per contact query and accuracy against Drake's hydroelastic centre of
  pressure for every method (Drake point and hydroelastic, polygon soup, MuJoCo, the
  paper's MLP and the improved predictor); re-creates the paper's Tables 3 and 4.
  `from testbed.studies.query import run_query_study` (a package: pose sets, one
  module per method family, measuring, statistics, rendering).
- sim, stability: the simulation-level study and the stability matrix (their modules).
- scale: what a yard of N containers costs with each contact model, and how far each lands
  from Drake hydroelastic (issue 29; `testbed study scale`).

Optional packages (python-fcl, mujoco, matplotlib) are imported only where used; a
missing one raises testbed.errors.OptionalDependencyError with the install command.
"""

from __future__ import annotations

__all__ = ["run_query_study"]


def __getattr__(name):
    if name == "run_query_study":
        from testbed.studies.query import run_query_study

        return run_query_study
    raise AttributeError(name)
