"""Wind: the load follows 0.5 rho v^2 Cd A, and friction balances it at rest."""

import math

import numpy as np
import pytest
from conftest import cached_run, last_step

from testbed.bodies.containers import CONTAINER_TYPES
from testbed.effects.wind import projected_area


def test_projected_area_of_a_yawed_box():
    L, W, H = CONTAINER_TYPES["1AA"].size
    y = np.array([0.0, 1.0, 0.0])
    assert projected_area((L, W, H), np.eye(3), y) == pytest.approx(L * H)
    c, s = math.cos(math.radians(30)), math.sin(math.radians(30))
    R = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    assert projected_area((L, W, H), R, y) == pytest.approx(L * H * c + W * H * s)


def test_ground_friction_balances_the_wind_at_rest():
    """Horizontal force balance on the whole stack: friction on the ground = total wind
    load within 1% (the stack is at rest after the 0.5 s ramp, so no inertia term)."""
    result = cached_run("windy_stack")
    wind = result.scenario.effects.wind
    L, W, H = CONTAINER_TYPES["1AA"].size
    n_boxes = len(result.scenario.containers)
    load = 0.5 * wind.air_density * wind.speed**2 * wind.drag_coefficient * L * H * n_boxes  # [N]
    c = result.tables["contacts"]
    rows = last_step(c) & (c["a"] == 0)
    friction_on_stack = c["ft_W"][rows].sum(axis=0)  # on b (the stack), from the ground
    assert friction_on_stack[1] == pytest.approx(-load, rel=0.01)
    # and the stack stays put: < 1 mm horizontal drift from 0.5 s after the ramp to the end
    s = result.tables["steps"]
    k = np.searchsorted(s["time"], wind.ramp_time + 0.5)
    assert np.max(np.abs(s["p_WB"][-1, :, :2] - s["p_WB"][k, :, :2])) < 1e-3
