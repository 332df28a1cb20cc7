"""The studies of `testbed study NAME` ("what does accuracy cost in time"), one plug-in each.

A study is one package here whose `__init__` registers a Study subclass (testbed/studies/base.py)
with `register`; `testbed study --help` lists every registered study and groups its options, and
adding one needs no edit elsewhere. Registered:

- sim: the simulation-level sweep (time step x contact model x approximation) and what each
  effect costs (sim/runs.py);
- query: time per contact query and accuracy against Drake's hydroelastic centre of pressure for
  every method; re-creates the paper's Tables 3 and 4 (a package: pose sets, one module per
  method family, measuring, statistics, rendering);
- stability: the stability matrix of hard cases (stability/matrix.py);
- defaults: contact settings judged over hard cases, shipped scenes and real tosses
  (defaults/judging.py);
- scale: what a yard of N containers costs per step with each contact model and engine, past the
  settling transient, and the cost's growth exponent in N (scale/: layout, cells, fit, report);
- truth: the truth ladder for motion (truth/).

Every study package's `__init__` stays light (no pydrake): its code is imported when it runs.
Optional packages (python-fcl, mujoco, matplotlib) are imported only where used; a missing one
raises testbed.errors.OptionalDependencyError with the install command.
"""

from __future__ import annotations

from testbed.errors import UnknownChoiceError
from testbed.plugins import PackageRegistry
from testbed.studies.base import Study

_REGISTRY = PackageRegistry(__name__, __path__, "study", instantiate=True, skip=("base",))
register = _REGISTRY.register


def studies() -> dict[str, Study]:
    """All studies by name (instances), in registry order."""
    return _REGISTRY.entries()


def study(name: str) -> Study:
    """The study `name`, or UnknownChoiceError naming the registered ones."""
    found = studies()
    if name not in found:
        raise UnknownChoiceError("study", name, found)
    return found[name]


__all__ = ["Study", "register", "run_query_study", "studies", "study"]


def __getattr__(name):
    if name == "run_query_study":
        from testbed.studies.query import run_query_study

        return run_query_study
    raise AttributeError(name)
