"""Physics of resting scenes: force balance, centre of pressure, load shares, stack height.

Tolerances (and why):
- 1% on force sums (the issue's gate). At rest the contact force balances gravity
  to solver tolerance; 1% leaves room for the residual settling motion after 1-2 s.
- 2 cm on the centre of pressure (the issue's gate); hydroelastic reaches ~0.2 mm.
- 2% on the bridge's support shares (the issue's gate).
- 5 mm on the 9-high stack's height drift (the issue's gate), 15 mm on its total
  compression below the nominal stacked height (9 contacts at ~1 mm each).
"""

import numpy as np
import pytest
from conftest import G, cached_run, last_step

COM_OFFSETS = [[0.0, 0.0, 0.0], [0.8, 0.3, 0.0]]


def _single(model, com):
    return cached_run(
        "defaults", f"effects.contact.model={model}", "effects.contact_log={}",
        f"containers[0].com_offset=[{com[0]}, {com[1]}, {com[2]}]", "duration=2.0",
    )


@pytest.mark.parametrize("com", COM_OFFSETS)
def test_hydroelastic_single_container_force_and_centre_of_pressure(com):
    result = _single("hydroelastic", com)
    c = result.tables["contacts"]
    rows = last_step(c)
    weight = result.scenario.containers[0].total_mass() * G
    assert abs(c["fn"][rows].sum() / weight - 1.0) < 0.01
    p_WCcm = _com_in_world(result, com)
    assert np.linalg.norm(c["p_W_cop"][rows][0, :2] - p_WCcm[:2]) < 0.02


def _com_in_world(result, com):
    q = result.final_positions  # [qw qx qy qz x y z] of the single free body
    from pydrake.common.eigen_geometry import Quaternion
    from pydrake.math import RotationMatrix

    R = RotationMatrix(Quaternion(q[:4] / np.linalg.norm(q[:4])))
    return q[4:7] + R.matrix() @ np.asarray(com)


@pytest.mark.parametrize("com", COM_OFFSETS)
def test_point_contact_single_container_time_averaged(com):
    """Point contact reports one corner per step (FCL's dBoxBox keeps the deepest of
    up to 4 points), so balance and centre of pressure hold on average: over the last
    second, the impulse-weighted mean force and point are checked."""
    result = _single("point", com)
    c = result.tables["contacts"]
    late = c["time"] >= 1.0
    steps = np.unique(c["step"][late]).size
    weight = result.scenario.containers[0].total_mass() * G
    assert abs(c["fn"][late].sum() / steps / weight - 1.0) < 0.01
    cop = (c["fn"][late, None] * c["p_W_cop"][late]).sum(0) / c["fn"][late].sum()
    assert np.linalg.norm(cop[:2] - _com_in_world(result, com)[:2]) < 0.02


@pytest.mark.xfail(strict=True, reason=(
    "Drake point contact keeps one corner of a face-on-face box contact per step "
    "(DESIGN.md section 3): measured 0.64 x weight at a corner ~3.2 m from the COM "
    "on the last step of a 2 s rest."))
def test_point_contact_single_container_per_step():
    result = _single("point", COM_OFFSETS[1])
    c = result.tables["contacts"]
    rows = last_step(c)
    weight = result.scenario.containers[0].total_mass() * G
    assert abs(c["fn"][rows].sum() / weight - 1.0) < 0.01
    assert np.linalg.norm(c["p_W_cop"][rows][0, :2] - _com_in_world(result, COM_OFFSETS[1])[:2]) < 0.02


def _ground_sum_at_rest(result, *, window: float):
    """Mean over the last `window` seconds of the sum of normal forces on the ground [N]."""
    c = result.tables["contacts"]
    ground = result.body_names.index("quay_ground")
    late = (c["time"] >= c["time"].max() - window) & (c["a"] == ground)
    return c["fn"][late].sum() / np.unique(c["step"][late]).size


@pytest.mark.parametrize("model", ["hydroelastic", "point"])
@pytest.mark.parametrize("scene", ["two_stack", "five_stack", "bridge"])
def test_ground_carries_total_weight(scene, model):
    result = cached_run(scene, f"effects.contact.model={model}")
    weight = sum(c.total_mass() for c in result.scenario.containers) * G
    # hydroelastic: last step; point contact hops between corners, so average 0.5 s
    window = 0.0 if model == "hydroelastic" else 0.5
    assert abs(_ground_sum_at_rest(result, window=window) / weight - 1.0) < 0.01


@pytest.mark.parametrize("model", ["hydroelastic", "point"])
def test_bridge_supports_carry_their_static_shares(model):
    result = cached_run("bridge", f"effects.contact.model={model}")
    c = result.tables["contacts"]
    names = result.body_names
    span = result.scenario.containers[2]
    window = 0.0 if model == "hydroelastic" else 0.5
    late = c["time"] >= c["time"].max() - window
    steps = np.unique(c["step"][late]).size
    # The span's COM is midway between the supports: each carries half its weight.
    for support in ("left", "right"):
        rows = late & (c["a"] == names.index(support)) & (c["b"] == names.index("span"))
        share = c["fn"][rows].sum() / steps / (span.total_mass() * G)
        assert abs(share - 0.5) < 0.5 * 0.02, (support, share)


@pytest.mark.slow
def test_nine_high_stack_holds_its_height():
    result = cached_run("nine_mixed_stack", "effects.contact.model=hydroelastic")
    steps = result.tables["steps"]
    top = steps["p_WB"][:, -1, 2]  # (n,) top container's height [m]
    settled = top[np.searchsorted(steps["time"], 0.5)]
    nominal = result.scenario.containers[-1].pose().translation()[2]
    assert abs(top[-1] - settled) < 5e-3
    assert 0.0 <= nominal - top[-1] < 15e-3
    assert steps["time"][-1] >= 5.0 - 1e-9
