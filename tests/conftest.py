"""Shared fixtures: scenes are simulated once per session and reused by several tests."""

import functools

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
