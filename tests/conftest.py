"""Shared fixtures: scenes are simulated once per session and reused by several tests."""

import functools
import importlib.util
import sys

import numpy as np
import pytest

from testbed import load_scenario, run_scenario

G = 9.81  # [m/s^2] Drake's default gravity


@functools.lru_cache(maxsize=None)
def cached_run(scene: str, *overrides: str):
    """Runs a shipped scene (or file) with overrides once per test session."""
    return run_scenario(load_scenario(scene, overrides=list(overrides)))


@pytest.fixture
def run():
    return cached_run


def last_step(table: dict) -> np.ndarray:
    """Boolean mask of the rows of the last logged step."""
    return table["step"] == table["step"].max()


# pyproject.toml's test extra installs torch==2.13.0 (a CPU build) only below Python 3.12.
NO_TORCH = ("needs torch, which the test extra installs only below Python 3.12 (its CPU build); training and the "
            "torch export do not depend on Drake's version, so the Python 3.11 suite (drake 1.51.1) runs them: "
            "what cannot differ between versions")


def pytest_collection_modifyitems(config, items):
    """Skips the tests marked `torch` on Python >= 3.12 when torch is not installed; below 3.12
    a missing torch fails them (the test extra must have installed it)."""
    if sys.version_info < (3, 12) or importlib.util.find_spec("torch") is not None:
        return
    for item in items:
        if item.get_closest_marker("torch"):
            item.add_marker(pytest.mark.skip(reason=NO_TORCH))
