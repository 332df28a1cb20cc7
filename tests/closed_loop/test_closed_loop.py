"""The learned_dynamics effect: a predictor drives container-container contact.

Physics on a resting two-stack (10 t with a 0.8 m off-centre payload on 20 t), the
force law against Drake, the compiled kernel against the numpy reference, the
stability check and the collision filter.
"""

import numpy as np
import pytest

from testbed.effects.learned_dynamics.force_law import FITTED_KAPPA, KAPPA_MODULUS, fit_pressure_stiffness
from testbed.effects.learned_dynamics.step import elastic
from testbed.errors import ScenarioError
from testbed.physics import GRAVITY
from testbed.scenario import load_scenario
from testbed.simulation import run_scenario

LEARNED = ["effects.learned_dynamics={}", "effects.shadow_contact=null"]


@pytest.fixture(scope="module")
def two_stack_run():
    scenario = load_scenario("two_stack", overrides=LEARNED + ["duration=0.5"])
    return scenario, run_scenario(scenario)


# (pair, relative bound): 0.1 % where both boxes have one footprint and one field depth (the constant is
# rounded to 5 digits; Drake's curve is linear within 0.05 %); 0.25 % where B's edges lie inside A's face
# or the fields differ (a half height on a full height): there the side faces' tetrahedra carry the
# edge strips, which the field slope E / (H_A + H_B) leaves out (measured 0.12 % for a 10 ft box on a
# 45 ft one, 0.17 % for a 20 ft half height on a 20 ft box)
KAPPA_PAIRS = [(("1CC", "1CC"), 1e-3), (("1CC", "1AA"), 1e-3), (("1AA", "1AAA"), 1e-3), (("1CX", "1CC"), 2.5e-3),
               (("1EEE", "1D"), 2.5e-3)]


@pytest.mark.parametrize("pair, bound", KAPPA_PAIRS)
def test_fitted_stiffness_is_drakes(pair, bound):
    kappa, deviation = fit_pressure_stiffness(*pair)  # fitted at KAPPA_MODULUS = 1e8 Pa, the law's own modulus
    assert kappa == pytest.approx(FITTED_KAPPA[frozenset(pair)], rel=bound)
    assert deviation < bound  # F(d) linear in d within it (the edge strips' share grows with the overlap)


# (roll, pitch, yaw) [rad], B's centre offset (x, y) [m], overlap at the centre [m]
POSES = [((0, 1e-5, 0), (0, 0), 1.6e-4), ((0, 1e-4, 0), (0, 0), 1.6e-4), ((0, 1e-3, 0), (0, 0), 1.6e-4),
         ((0, 1e-2, 0), (0, 0), 1.6e-4), ((0, 3e-2, 0), (0, 0), 1e-3), ((1e-2, 0, 0), (0, 0), 1.6e-4),
         ((3e-3, 3e-3, 0), (0, 0), 5e-4), ((0, 0, 0), (1.0, 0.3), 2e-4), ((0, 2e-3, 0), (1.5, -0.5), 3e-4)]


def _drake_and_law(rpy, offset, overlap):
    from pydrake.geometry import HydroelasticContactRepresentation

    from testbed.contact.pair_plant import ContainerPair
    from testbed.contact.surfaces import static_pressure, surface_face_arrays
    from testbed.geometry.rotations import rotation_from_rpy

    h = np.array([3.029, 1.219, 1.2955])  # 1CC half extents [m]
    R = rotation_from_rpy(np.array([rpy], dtype=float))[0]
    p = np.array([offset[0], offset[1], 2 * h[2] - overlap])
    (surface,) = ContainerPair("1CC", "1CC", modulus=KAPPA_MODULUS).set_pose(p, R).ComputeContactSurfaces(HydroelasticContactRepresentation.kPolygon)
    drake = np.linalg.norm(static_pressure(surface_face_arrays(surface)).force)
    law = elastic(p, R, h, h, FITTED_KAPPA[frozenset(["1CC"])], 4)[0]
    return drake, law


@pytest.mark.parametrize("rpy, offset, overlap", POSES)
def test_foundation_force_is_drakes(rpy, offset, overlap):
    """The law's reason to exist: at 1e-4 rad of pitch k * d_SAT is 2.6x Drake's force."""
    drake, law = _drake_and_law(rpy, offset, overlap)
    # 2 %: the integral is exact along the steeper face axis; what remains is the 4-point rule
    # across it (combined tilts) and Drake's field bending away from linear 0.05 m deep (3e-2 rad)
    assert law == pytest.approx(drake, rel=2e-2)


@pytest.mark.parametrize("rpy, offset, band", [(((0, 2e-3, 1e-2)), (1.5, -0.5), (1.01, 1.04)),
                                              ((0, 0, 0.2), (0, 0), (1.10, 1.20))])
def test_foundation_force_overestimates_yawed_faces(rpy, offset, band):
    """A known limit, pinned: the overlap is the bounding rectangle of the yawed face
    (measured +2.2 % at 1e-2 rad of yaw with an offset, +14.6 % at 0.2 rad)."""
    drake, law = _drake_and_law(rpy, offset, 3e-4)
    assert band[0] < law / drake < band[1]


def test_resting_two_stack_force_balance(two_stack_run):
    scenario, result = two_stack_run
    weight = GRAVITY * sum(c.total_mass() for c in scenario.containers)
    contacts = result.tables["contacts"]
    last = contacts["step"] > contacts["step"].max() - 100  # the last 0.1 s
    # 1 %: at rest the ground carries the whole stack; what remains is the settling oscillation
    assert contacts["fn"][last].sum() / 100 == pytest.approx(weight, rel=1e-2)
    table = result.tables["closed_loop"]
    top = GRAVITY * scenario.containers[1].total_mass()
    tail = table["step"] > table["step"].max() - 100
    assert table["fn"][tail].mean() == pytest.approx(top, rel=1e-2)


def test_resting_two_stack_holds_and_creates_no_energy(two_stack_run):
    scenario, result = two_stack_run
    steps = result.tables["steps"]
    z0, p_end = steps["p_WB"][0, 1], steps["p_WB"][-1, 1]
    # the stack compresses by 10 t g / 6.06e8 N/m (0.16 mm, container pair) plus the quay's
    # hydroelastic compression under 30 t (~0.25 mm): the top may sink <= 1 mm, no more
    assert 0 < z0[2] - p_end[2] < 1e-3
    # sideways: Drake's own run drifts ~0.1 mm here; the learned point's offset from Drake's
    # centre of pressure tilts the top box until its point is under the payload: <= 0.5 mm
    assert np.linalg.norm(p_end[:2] - z0[:2]) < 5e-4
    energy = steps["kinetic_energy"] + steps["potential_energy"]
    # energy not created: 1 J against a potential of ~8e5 J (explicit forces could pump it)
    assert np.max(energy - energy[0]) < 1.0


def test_container_pairs_are_off_drakes_contact(two_stack_run):
    _, result = two_stack_run
    contacts = result.tables["contacts"]
    assert len(contacts["a"]) and np.all(contacts["a"] == 0)  # only quay-container rows
    table = result.tables["closed_loop"]
    assert set(zip(table["a"], table["b"])) == {(1, 2)}


def test_shadow_truth_is_drakes_force_at_the_same_pose(two_stack_run):
    _, result = two_stack_run
    table = result.tables["closed_loop"]
    has = table["has_truth"]
    assert has.sum() >= 20  # 0.5 s sampled every 20 steps: 26 rows of the one pair
    rel = np.abs(table["fn"][has] / table["fn_truth"][has] - 1)
    # median 1 %: same fitted stiffness on the same pose; only Hunt-Crossley damping differs
    assert np.median(rel) < 1e-2
    assert np.all(np.isfinite(table["point_error"][has]))


def test_shadow_truth_is_sampled_at_its_period_and_matches_every_step(two_stack_run):
    """Rows carry a truth answer exactly on steps 0, N, 2N, ... (NaN elsewhere, counted in
    the summary), and those answers are the every-step run's on the same steps."""
    from testbed.effects.learned_dynamics.truth import TRUTH_COLUMNS

    scenario, _ = two_stack_run
    every = scenario.effects.learned_dynamics.truth_every_steps
    assert every > 1  # the default samples
    runs = {n: run_scenario(load_scenario("two_stack", overrides=LEARNED + [
        "duration=0.06", f"effects.learned_dynamics.truth_every_steps={n}"])) for n in (1, 7)}
    sampled, full = runs[7].tables["closed_loop"], runs[1].tables["closed_loop"]
    assert np.array_equal(sampled["has_truth"], sampled["step"] % 7 == 0) and sampled["has_truth"].sum() >= 8
    assert np.all(full["has_truth"])
    absent = ~sampled["has_truth"]
    for column in ("fn_truth", "point_error", "normal_error_deg"):
        assert np.all(np.isnan(sampled[column][absent]))
    assert np.all(np.isnan(sampled["p_W_truth"][absent]))
    # the same steps, pairs and learned answers (the truth never feeds back into the run) ...
    for column in ("step", "a", "b", "fn", "p_W"):
        np.testing.assert_array_equal(sampled[column], full[column])
    # ... and the same truth where both have one: the same pose through the same pair plant
    # (1e-12 relative: nothing but floating-point evaluation order could differ)
    has = sampled["has_truth"]
    for column in TRUTH_COLUMNS[1:]:
        np.testing.assert_allclose(sampled[column][has], full[column][has], rtol=1e-12, atol=1e-15)
    summary = runs[7].summary
    assert summary["closed_loop_truth_every_steps"] == 7
    assert summary["closed_loop_truth_rows"] == has.sum()
    assert summary["closed_loop_point_error_rows"] == np.isfinite(sampled["point_error"]).sum()
    assert summary["closed_loop_rows"] == len(sampled["a"])
    # the summary's errors are over the sampled rows only, not NaN read as zero
    assert summary["closed_loop_point_error_median_m"] == pytest.approx(np.median(sampled["point_error"][has]))


def test_truth_every_steps_must_be_a_whole_number():
    with pytest.raises(ScenarioError, match="effects.learned_dynamics.truth_every_steps"):
        load_scenario("two_stack", overrides=LEARNED + ["effects.learned_dynamics.truth_every_steps=0"])


SIDEWAYS = """
name: closed_loop_sideways
duration: 1.0
containers:
- {name: base, type: 1CC, mass: 20000.0, fixed: true, X_WC: {translation: [0.0, 0.0, 1.2955]}}
- {name: top, type: 1CC, X_WC: {translation: [0.0, 0.0, 3.8865]}}
effects:
  contact: {}
  friction: {}
  wind: {speed: 15.0, direction_deg: 90.0, ramp_time: 0.2}
  learned_dynamics: {stick_hw: %s}
"""


@pytest.mark.parametrize("stick_hw", [0.3, 0.0])
def test_stick_holds_a_sideways_load(stick_hw):
    """An empty 20 ft box on a welded one, pushed sideways by 2.6 kN of wind (30 % of mu m g)."""
    from testbed.compare.runs import run_variant

    run = run_variant(load_scenario(text=SIDEWAYS % stick_hw), 1.0, 50)
    y = run.p_WB[:, 0, 1]  # [m], records every 50 ms
    creep = abs(y[-1] - y[8])  # from t = 0.4 s (wind at full strength since 0.2 s) to 1 s
    if stick_hw > 0:
        # the anchored spring holds: measured 8e-8 m; 1e-5 m bounds the tilt settling
        assert creep < 1e-5
    else:
        # the regularised law creeps at T / c = 2.6 kN / (0.5 m / h): ~2.4 mm/s (measured 1.4 mm)
        assert creep > 5e-4


def test_predictor_path_from_the_scene_file(tmp_path):
    with pytest.raises(ScenarioError, match="effects.learned_dynamics.predictor"):
        load_scenario("two_stack", overrides=LEARNED + [f"effects.learned_dynamics.predictor={tmp_path / 'x.npz'}"])


DROP = """
name: closed_loop_drop
duration: 1.0
containers:
- {name: base, type: 1CC, mass: 20000.0, X_WC: {translation: [0.0, 0.0, 1.2955]}}
- {name: top, type: 1CC, mass: %s, X_WC: {translation: [0.0, 0.0, 3.9865], rotation: !Rpy {deg: [0.5, 0.3, 0]}}}
effects:
  contact: {}
  friction: {}
"""


@pytest.mark.parametrize("mass", [10000.0, 2200.0])
def test_drop_lands_like_drake_and_creates_no_energy(mass):
    """A box dropped 0.1 m, tilted 0.5 / 0.3 deg, onto a free one: an impact, not a rest."""
    from testbed.compare.runs import run_variant, variant

    scenario = load_scenario(text=DROP % mass)
    truth, learned = (run_variant(variant(scenario, kind), 1.0, 1) for kind in ("truth", "learned"))
    assert not learned.error
    # energy not created: E = kinetic + gravity potential never rises above E(0) (the
    # contact's elastic energy is not in E, so E may dip and recover while compressed)
    assert np.max(learned.energy - learned.energy[0]) <= 1e-6 * abs(learned.potential[0])
    # it settles at Drake's height: 0.1 mm (the compression under 10 t is 0.16 mm)
    assert np.abs(learned.p_WB[-1, :, 2] - truth.p_WB[-1, :, 2]).max() < 1e-4
    # the tilted impact kicks the top box sideways. Measured at the twins' 1e8 Pa: Drake slides 29 mm
    # (10 t) / 27.5 mm (2.2 t); the law's end points lie 1.0 / 4.3 mm from Drake's since its force is
    # the exact field contact and Hunt-Crossley's damping acts over the whole surface (its torque from
    # the pressure spread, grid 0); with the Winkler foundation damped at the point only (grid 4) they
    # were 20.9 / 27.7 mm apart, the rocking after the impact undamped. Bound: half the closed-loop
    # gates' 2 cm, so that the foundation's figure fails it.
    apart = np.linalg.norm(learned.p_WB[-1, :, :2] - truth.p_WB[-1, :, :2], axis=1).max()
    assert apart < 1e-2


def test_runs_with_crane_meshcat_and_contact_log():
    scenario = load_scenario("crane_hard_landing", overrides=[
        "effects.learned_dynamics={}", "effects.meshcat={port: 0, record: true}", "duration=0.05"])
    result = run_scenario(scenario)
    assert "<html" in result.files["replay.html"][:2000].lower()
    assert result.summary["learned_dynamics_predictor"] == "improved"
    assert len(result.tables["closed_loop"]["a"])  # the stack's pairs are recorded with Drake's answer


@pytest.mark.slow
def test_crane_seats_on_learned_contact():
    """The twistlocks release when the load is seated: with container pairs off Drake's
    contact, the crane asks the learned system whether its container touches."""
    release = {}
    same = ["effects.contact.hydroelastic_modulus=1e8"]  # Drake at the learned law's modulus (KAPPA_MODULUS)
    for kind, overrides in (("drake", same), ("learned", ["effects.learned_dynamics={shadow_truth: false}"])):
        release[kind] = run_scenario(load_scenario("crane_hard_landing", overrides=overrides)).summary["crane_release_time_s"]
    assert release["learned"] is not None
    # 10 ms: the seating test runs every 1 ms step; measured 0.809 s vs Drake's 0.806 s
    assert release["learned"] == pytest.approx(release["drake"], abs=1e-2)
