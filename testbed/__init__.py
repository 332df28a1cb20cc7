"""Container contact testbed: Drake container scenes, ground-truth contact records,
and comparisons with learned contact models.

Importing this package is cheap: the names below load their modules (and pydrake)
on first use, so `from testbed.errors import TestbedError` pulls in neither pydrake
nor torch, and nothing starts a server.
Main entry points: `load_scenario`, `build_scene`, `simulate`, `run_scenario`.
"""

import importlib

__version__ = "0.11.0"

_EXPORTS = {
    "ModelError": "testbed.errors", "ScenarioError": "testbed.errors", "SimulationError": "testbed.errors",
    "TestbedError": "testbed.errors", "UnknownChoiceError": "testbed.errors",
    "Scenario": "testbed.scenario", "load_scenario": "testbed.scenario", "shipped_scenes": "testbed.scenario",
    "build_scene": "testbed.builder", "run_scenario": "testbed.simulation", "simulate": "testbed.simulation",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name):
    if name in _EXPORTS:
        value = getattr(importlib.import_module(_EXPORTS[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'testbed' has no attribute {name!r}")


def __dir__():
    return sorted(list(globals()) + __all__)
