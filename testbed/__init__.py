"""Container contact testbed: Drake container scenes, ground-truth contact records,
and comparisons with learned contact models.

Importing this package loads pydrake and numpy only (no torch, no servers).
Main entry points: `load_scenario`, `build_scene`, `simulate`, `run_scenario`.
"""

from testbed.errors import ModelError, ScenarioError, TestbedError, UnknownChoiceError
from testbed.scenario import Scenario, load_scenario, shipped_scenes
from testbed.builder import build_scene
from testbed.simulate import run_scenario, simulate

__version__ = "0.1.0"

__all__ = [
    "ModelError", "Scenario", "ScenarioError", "TestbedError", "UnknownChoiceError",
    "build_scene", "load_scenario", "run_scenario", "shipped_scenes", "simulate",
]
