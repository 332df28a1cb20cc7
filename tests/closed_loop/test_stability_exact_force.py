"""The learned effect's stability check (force_law.stability_numbers) against the force the loop now
applies (the exact field contact, grid 0): the tilt stiffness it checks below (h w)^2 < 4 must be at
least the exact force's, or a pose the check passed could still be unstable in the explicit tilt.

Measured (2026-12-07, 1e8 Pa, 2 mm overlap, tilts of +-1e-5 rad about the contact face's centre): the
exact moment's tilt stiffness is 0.997-0.999x the check's kappa l w^3 / 12 on aligned faces (the check
takes the whole face overlap, the largest any pose has); offsets, yaw and tilt give less. The normal
force and the Hunt-Crossley damping (force and torque) are implicit per pair, so they do not enter
the explicit criterion; the damping torque's own stability is checked in the loop below (a stack at
the largest step the check allows keeps its energy).
"""

from __future__ import annotations

import numpy as np
import pytest

from testbed.bodies.containers import CONTAINER_TYPES
from testbed.effects.learned_dynamics.force_law import pressure_stiffness
from testbed.effects.learned_dynamics.static import static_answer
from testbed.geometry.rotations import rotation_from_rpy

TILT = 1e-5  # [rad] central-difference half step (the moment is linear in tilt to 1e-6 here)


def _tilt_stiffness(type_a, type_b, offset, yaw_deg, depth) -> np.ndarray:
    """(2,) [N m/rad] -dM/dtheta about A's x and y axes through the contact face's centre, B on A's top
    face at `offset` (x, y) [m], yawed `yaw_deg`, overlapping `depth` [m]."""
    s_a, s_b = np.array(CONTAINER_TYPES[type_a].size), np.array(CONTAINER_TYPES[type_b].size)
    R0 = rotation_from_rpy(np.array([[0.0, 0.0, np.radians(yaw_deg)]]))[0]
    p0 = np.array([offset[0], offset[1], 0.5 * (s_a[2] + s_b[2]) - depth])
    c = np.array([offset[0], offset[1], 0.5 * s_a[2] - 0.5 * depth])  # the contact face's centre in A
    k = np.zeros(2)
    for axis in (0, 1):
        m = []
        for sign in (1.0, -1.0):
            rpy = np.zeros(3)
            rpy[axis] = sign * TILT
            R_t = rotation_from_rpy(rpy[None])[0]
            answer = static_answer((c + R_t @ (p0 - c))[None], (R_t @ R0)[None], s_a, s_b)
            m.append((answer.moment[0] - np.cross(c, answer.force[0]))[axis])
        k[axis] = -(m[0] - m[1]) / (2 * TILT)
    return k


def _checked(type_a, type_b, axis: int = 0) -> float:
    """[N m/rad] kappa x the whole face overlap's second moment about A's `axis` through its centre:
    axis 0 (roll, l w^3 / 12) is force_law.stability_numbers' tilt stiffness."""
    s_a, s_b = np.array(CONTAINER_TYPES[type_a].size), np.array(CONTAINER_TYPES[type_b].size)
    l, w = np.minimum(s_a, s_b)[:2]
    return pressure_stiffness(type_a, type_b) * (l * w**3 if axis == 0 else w * l**3) / 12.0


@pytest.mark.parametrize("types", [("1CC", "1CC"), ("1AA", "1CC"), ("1AA", "1AA")])
def test_aligned_faces_tilt_as_the_check_assumes(types):
    k = _tilt_stiffness(*types, (0.0, 0.0), 0.0, 2e-3)
    ratio = k[0] / _checked(*types)
    assert 0.99 < ratio <= 1.0, ratio  # measured 0.9972-0.9973; a law twice as stiff in tilt fails


@pytest.mark.parametrize("types,offset,yaw,depth", [
    (("1CC", "1CC"), (0.4, 0.1), 0.0, 2e-3), (("1AA", "1CC"), (2.0, -0.3), 3.0, 5e-3),
    (("1AA", "1AA"), (0.0, 0.0), 35.0, 1e-3), (("1AA", "1CC"), (-4.0, 0.2), 90.0, 3e-3),
    (("1CC", "1CC"), (3.0, 0.0), 0.0, 2e-3)])
def test_no_resting_pose_is_stiffer_in_tilt_than_the_whole_overlap(types, offset, yaw, depth):
    k = _tilt_stiffness(*types, offset, yaw, depth)
    assert np.all(k > 0), k  # restoring: a sign error in the moment fails here
    for axis in (0, 1):
        assert k[axis] <= 1.001 * _checked(*types, axis), (axis, k, _checked(*types, axis))


PAIR = """
name: tilted_landing_check
duration: 1.0
plant: {{time_step: {h}}}
containers:
- {{name: a, type: 1AA, mass: 3750.0, fixed: true, X_WC: {{translation: [0, 0, 1.2955]}}}}
- {{name: b, type: 1AA, mass: 3750.0, X_WC: {{translation: [0, 0, 3.9194], rotation: !Rpy {{deg: {rpy}}}}}}}
effects: {{contact: {{model: point, hydroelastic_modulus: 1.0e9}}, friction: {{}}, learned_dynamics: {{}}}}
"""


def _landing(h: float, rpy):
    """An empty 40 ft box tilted 0.3 deg, its lowest end 1 mm above a fixed one, at 1e9 Pa (the
    stiffest modulus the law runs at), released: (explicit check number, trajectory)."""
    from testbed.compare.runs import run_variant
    from testbed.scenario import load_scenario
    from testbed.scenario.spec import _CHECKED

    scenario = load_scenario(text=PAIR.format(h=h, rpy=list(rpy)))
    check = max(r["explicit"] for r in getattr(scenario, _CHECKED)[1]["learned_dynamics"].stability)
    return check, run_variant(scenario, 1.0, 1)


def _judged(run):
    """(energy above the start [J], speed at the end [m/s], weight x 1 m x the stress suite's tolerance [J])."""
    from testbed.physics import GRAVITY
    from testbed.studies.stability.matrix import ENERGY_TOLERANCE

    gained = float(np.max(run.energy - run.energy[0]))
    return gained, float(np.linalg.norm(run.V_WB[-1, 0, 3:])), ENERGY_TOLERANCE * 3750.0 * GRAVITY * 1.0


@pytest.mark.parametrize("rpy", [(0.0, 0.3, 0.0), (0.3, 0.0, 0.0)], ids=["pitched", "rolled"])
def test_a_tilted_landing_at_1ms_rests_and_creates_no_energy(rpy):
    """Measured: check 1.52; energy above the start 0.0 J; 7e-10 / 1e-10 m/s after 1 s."""
    check, run = _landing(1e-3, rpy)
    gained, speed, allowed = _judged(run)
    assert not run.error and check < 4.0
    assert gained <= allowed, (gained, allowed)
    assert speed < 1e-6, speed


@pytest.mark.xfail(strict=True, raises=AssertionError, reason="at the largest step the check accepts (1.6 ms: (h w)^2 = 3.9) the landing "
                   "neither diverges nor comes to rest: 2.2-4.4 mm/s after 1 s, 4.8 mm/s at most over its last 0.2 s "
                   "(translational; the tilt rate is 5e-5 to 2e-3 rad/s), energy never above the start")
def test_at_the_checks_largest_step_a_tilted_landing_rests():
    for rpy in [(0.0, 0.3, 0.0), (0.3, 0.0, 0.0)]:
        check, run = _landing(1.6e-3, rpy)
        gained, speed, allowed = _judged(run)
        if run.error or not 3.5 < check < 4.0 or gained > allowed or not 1e-3 < speed < 1e-2:
            pytest.fail(f"not the pinned failure (band 1-10 mm/s): {run.error} {check} {gained} {speed}")
        assert speed < 1e-6, speed
