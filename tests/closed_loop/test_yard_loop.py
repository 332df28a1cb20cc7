"""The learned loop at yard scale: the stability check loads a pair
with what its upper box carries (its column), and candidate pairs come from a broad phase.

The truly unstable stack: the normal force is linearly implicit since the heavy-on-empty landing
(below), so the check judges the part that stays explicit, the tilt stiffness: three empty 40 ft
boxes (3.75 t) at 1e9 Pa and a 2.5 ms step are refused. (With the explicit normal force the
same boxes at 1e8 Pa and 2.5 ms had (h w)^2 = 9.6 and diverged at t = 0.058 s.) The side-by-side check: an empty box under three
28 t ones (2.5 + 0.74 stiffness: stable) stays stable beside a twin stack 0.4 m away, which the
old check (every container at or above the pair) summed into 5.7 and refused.
"""

from pathlib import Path

import numpy as np
import pytest

from testbed import shipped_scenes
from testbed.effects.learned_dynamics.force_law import carried_masses
from testbed.effects.learned_dynamics.step import candidate_pairs
from testbed.errors import ScenarioError
from testbed.scenario import load_scenario

HEAVY_ON_EMPTY = Path(__file__).resolve().parents[1] / "scenes" / "heavy_on_empty.yaml"

LEARNED = ["effects.learned_dynamics={}", "effects.shadow_contact=null"]

STACK = """
name: column
duration: 0.2
yards:
- {{name: s, type: 1AA, rows: {rows}, tiers: {tiers}, masses: {masses}}}
effects: {{contact: {{model: point}}, friction: {{}}, learned_dynamics: {{}}}}
"""


def _stack(rows, masses):
    return STACK.format(rows=rows, tiers=len(masses), masses=list(masses))


def test_a_truly_unstable_stack_is_refused():
    """The normal force is linearly implicit (any step); what stays explicit is the tilt stiffness
    (the contact point moving with the tilt): (h w_tilt)^2 = 19 for three empty boxes at 1e9 Pa and
    2.5 ms, refused; 3.0 at 1 ms, accepted. (An aligned stack does not excite that mode: with the
    check off it ran 0.5 s at 2.5 ms in the MuJoCo host, measured.)"""
    text = _stack(1, [3750.0] * 3).replace("duration: 0.2", "duration: 0.2\nplant: {time_step: 0.0025}").replace(
        "{model: point}", "{model: point, hydroelastic_modulus: 1.0e9}")
    with pytest.raises(ScenarioError) as info:
        load_scenario(text=text)
    message = str(info.value)
    assert "'s_r1_b1_t1'-'s_r1_b1_t2'" in message and "unstable at plant.time_step = 0.0025 s" in message, message
    assert "\n" not in message
    load_scenario(text=text.replace("0.0025", "0.001"))  # 3.0: accepted


def test_side_by_side_stacks_do_not_load_each_other():
    single = load_scenario(text=_stack(1, [3750.0] + [28000.0] * 3))
    twin = load_scenario(text=_stack(2, [3750.0] + [28000.0] * 3))  # 0.4 m apart: was refused (5.7)
    worst = [max(max(r["normal"], r["tilt"]) for r in s.effects.learned_dynamics and
                 _checked(s).stability) for s in (single, twin)]
    assert worst[0] == pytest.approx(worst[1], rel=1e-12) and worst[0] < 4.0
    assert carried_masses(twin.containers).tolist() == [87750.0, 84000.0, 56000.0, 28000.0] * 2


def _checked(scenario):
    from testbed.scenario.spec import _CHECKED

    return getattr(scenario, _CHECKED)[1]["learned_dynamics"]


def test_a_box_on_two_carries_into_both():
    text = """
name: bridge_like
containers:
- {name: left, type: 1CC, mass: 10000.0, X_WC: {translation: [-3.048, 0, 1.2955]}}
- {name: right, type: 1CC, mass: 8000.0, X_WC: {translation: [3.048, 0, 1.2955]}}
- {name: span, type: 1AA, mass: 20000.0, X_WC: {translation: [0, 0, 3.8865]}}
- {name: top, type: 1CC, mass: 5000.0, X_WC: {translation: [3.0, 0, 6.4775]}}
"""
    assert carried_masses(load_scenario(text=text).containers).tolist() == [35000.0, 33000.0, 25000.0, 5000.0]


YARDS = sorted(n for n in shipped_scenes() if n.startswith("yard"))


@pytest.mark.parametrize("name", YARDS)
def test_every_shipped_yard_is_accepted_at_its_1ms_step(name):
    scenario = load_scenario(name, overrides=LEARNED)
    assert scenario.plant.time_step == 1e-3
    worst = max(max(r["normal"], r["tilt"]) for r in _checked(scenario).stability)
    assert worst < 4.0


def _near_all_pairs(p, R, half, free, margin):
    """The candidates by brute force, in numpy (the oracle): every pair i < j with one body
    free whose bounding spheres are within margin and no face axis (A's 3, B's 3) separates
    by more than margin: (ia, ib, p_AB (k, 3), R_AB (k, 3, 3))."""
    radius = np.linalg.norm(half, axis=1)
    ia, ib = np.triu_indices(len(p), 1)
    keep = free[ia] | free[ib]
    keep &= np.sum((p[ib] - p[ia]) ** 2, axis=1) < (radius[ia] + radius[ib] + margin) ** 2
    ia, ib = ia[keep], ib[keep]
    p_AB = np.einsum("kca,kc->ka", R[ia], p[ib] - p[ia])
    R_AB = np.einsum("kca,kce->kae", R[ia], R[ib])
    hA, hB = half[ia], half[ib]
    over_A = hA - np.abs(p_AB) + np.einsum("kij,kj->ki", np.abs(R_AB), hB)
    over_B = hB - np.abs(np.einsum("kij,ki->kj", R_AB, p_AB)) + np.einsum("kij,ki->kj", np.abs(R_AB), hA)
    near = np.minimum(over_A.min(axis=1), over_B.min(axis=1)) > -margin
    return ia[near], ib[near], p_AB[near], R_AB[near]


@pytest.mark.parametrize("name", ["nine_mixed_stack", "bridge", "crane_landing_sway", "stack_slide_rest", "yard_small", "yard_crane_slot"])
def test_the_broad_phase_finds_the_pairs_all_pairs_find(name):
    """On shipped scenes' poses, shaken (tilts to 0.1 rad, shifts to 0.3 m, seeded), the native
    step's candidates (broad phase, then the narrow tests) are exactly the pairs a brute-force
    test of all N(N-1)/2 keeps, in the same (ia, ib) order, with the same poses in A."""
    specs = load_scenario(name).containers
    size = np.array([np.asarray(c.container_type().size) for c in specs], dtype=float)
    half = 0.5 * size
    free = np.array([not c.fixed for c in specs])
    p0 = np.array([c.pose().translation() for c in specs])
    rng = np.random.default_rng(29)
    found = 0
    for trial in range(50):
        scale = trial / 50
        p = p0 + scale * rng.uniform(-0.3, 0.3, p0.shape)
        R = []
        for _ in specs:
            a, b, c = scale * rng.uniform(-0.1, 0.1, 3)
            Rx = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
            Ry = np.array([[np.cos(b), 0, np.sin(b)], [0, 1, 0], [-np.sin(b), 0, np.cos(b)]])
            Rz = np.array([[np.cos(c), -np.sin(c), 0], [np.sin(c), np.cos(c), 0], [0, 0, 1]])
            R.append(Rz @ Ry @ Rx)
        R = np.array([Ri @ c.pose().rotation().matrix() for Ri, c in zip(R, specs)])
        ia, ib, p_AB, R_AB = _near_all_pairs(p, R, half, free, 0.05)
        ca, cb, p_AB2, R_AB2, n_broad = candidate_pairs(size, free, p, R, 0.05)
        assert np.array_equal(np.stack([ia, ib]), np.stack([ca, cb]))
        np.testing.assert_allclose(p_AB2, p_AB, rtol=0, atol=1e-12)
        np.testing.assert_allclose(R_AB2, R_AB, rtol=0, atol=1e-14)
        assert n_broad >= len(ca)
        found += len(ca)
    assert found > 0


def test_the_broad_phase_grows_about_linearly_on_a_yard():
    """Candidates per container stay bounded as the block grows (4 x 6 x 4 -> 6 x 8 x 4)."""
    counts = []
    for rows, bays in ((2, 2), (4, 6), (6, 8)):
        specs = load_scenario("yard_block", overrides=[f"yards[0].rows={rows}", f"yards[0].bays={bays}"]).containers
        size = np.array([np.asarray(c.container_type().size) for c in specs], dtype=float)
        p = np.array([c.pose().translation() for c in specs])
        R = np.array([np.eye(3)] * len(specs))
        *_, n_broad = candidate_pairs(size, np.ones(len(specs), bool), p, R, 0.05)
        counts.append(n_broad / len(specs))
        assert n_broad == rows * bays * 3  # the stacked pairs, nothing across the 0.4 / 0.6 m gaps
    assert max(counts) < 1.0


@pytest.mark.parametrize("modulus", [1e8, 1e9])
def test_a_heavy_load_lands_on_an_empty_box_in_both_hosts(modulus):
    """tests/scenes/heavy_on_empty.yaml: a 25 t load at 1 m/s onto an empty 40 ft box (3.75 t) on
    two loaded ones. The explicit law blew up within 6 ms of touchdown in both learned loops
    (its damping term 2 h d F / m reached ~10 at the impact force; the build check, on the static
    load, said 1.65); the linearly implicit normal force lands it within the closed-loop gates
    against Drake hydroelastic, at the learned law's 1e8 Pa and at the shipped 1e9 Pa."""
    from testbed.compare import compare_engine
    from testbed.compare.runs import run_variant, variant
    from testbed.gates.closed_loop import FINAL_ANGLE_TOL_DEG, FINAL_POSITION_TOL_M, MAX_PENETRATION_M

    scenario = load_scenario(HEAVY_ON_EMPTY, overrides=[f"effects.contact.hydroelastic_modulus={modulus}"])
    truth, learned = (run_variant(variant(scenario, kind), 0.6, 10) for kind in ("truth", "learned"))
    assert not learned.error
    apart = np.abs(learned.p_WB[-1] - truth.p_WB[-1]).max()
    if modulus == 1e8:
        assert apart < FINAL_POSITION_TOL_M
        # nearly at rest (Drake: 7e-6 m/s at 0.6 s); measured under 1e-3 m/s
        assert np.abs(learned.V_WB[-1]).max() < 1e-3
    else:
        # A known gap of the Drake-hosted loop at 1e9 Pa (10x the law's default modulus): with the
        # exact field force and Hunt-Crossley's torque over the surface the load walks 25.7 mm sideways
        # in 0.6 s (the foundation damped at the point only: 0.7 mm; without the torque 0.67 mm), while
        # the MuJoCo-hosted loop with the same law lands it within 0.06 mm (below). Pinned in a band:
        # worse fails, and under 5 mm the pin is stale.
        assert 5e-3 < apart < 5e-2, apart
        assert np.abs(learned.V_WB[-1]).max() < 1e-1
    f = compare_engine(scenario, "mujoco_learned", duration=0.6, with_point=False, bare_truth=False)
    assert f["hydroelastic_modulus_Pa"] == modulus and not f["diverged"]
    assert f["final_position_error_max_m"] < FINAL_POSITION_TOL_M and f["final_angle_error_max_deg"] < FINAL_ANGLE_TOL_DEG
    assert f["max_penetration_m"] < MAX_PENETRATION_M
