"""The contact-defaults sweep (testbed/studies/defaults/judging.py, `testbed study defaults`).

The verdicts are checked on a case whose physics is known: a 20 t box released 2 mm above
a fixed one ("resting_pair") and left to settle for 1 s. The shipped setting must pass every
criterion there, and two settings that are wrong on purpose must fail the criterion they break.
"""

import json
import subprocess
import sys

import pytest

from testbed.document import to_html, to_markdown
from testbed.studies.defaults import CRITERIA, TOSS_ERROR_BOUND, Setting, grid, learned_loop_stability, report_sections, summarize, sweep

SHIPPED = Setting(1e9, "similar", 0.0, 1e-3)  # sdf/README.md: chosen from this sweep
# 1e5 Pa: a soft foam. Measured: the box sinks about 670 mm into the lower one in 0.5 s (bound 5 mm).
SOFT = Setting(1e5, "sap", 0.0, 1e-3)
# h = 0.1 s, the largest step a scene accepts: the 2 mm drop lands within one step, measured
# penetration 96 mm and an energy gain of 2.3e4 J (tolerance 196 J = 1e-3 x m g x 1 m).
COARSE = Setting(1e8, "sap", 0.0, 1e-1)


@pytest.fixture(scope="module")
def judged():
    """Summary rows of the three settings on the resting pair (in this process), by label."""
    rows = sweep([SHIPPED, SOFT, COARSE], ("resting_pair",), workers=1, duration=1.0)
    return rows, {o["label"]: o for o in summarize(rows)}


def test_the_modulus_reaches_every_geometry():
    """effects.contact.hydroelastic_modulus is written on every geometry's proximity properties."""
    from testbed.builder import build_scene
    from testbed.scenario import load_scenario

    scene = build_scene(load_scenario("two_stack", overrides=["effects.contact.hydroelastic_modulus=3e9"]))
    inspector = scene.scene_graph.model_inspector()
    moduli = {inspector.GetProximityProperties(g).GetProperty("hydroelastic", "hydroelastic_modulus")
              for g in inspector.GetAllGeometryIds() if inspector.GetProximityProperties(g) is not None
              and inspector.GetProximityProperties(g).HasProperty("hydroelastic", "hydroelastic_modulus")}
    assert moduli == {3e9}


def test_shipped_setting_passes_every_criterion_at_rest(judged):
    _, by_label = judged
    o = by_label[SHIPPED.label]
    # cost is a timing ratio: reported, never asserted in a test; toss has its own test below; the
    # learned loop's criterion is not a property of the truth (its own test below)
    physics = [c for c in CRITERIA if c not in ("cost", "toss", "learned_loop")]
    assert {c: o["verdicts"][c] for c in physics} == {c: "pass" for c in physics}, o["failures"]
    # stability.py's bounds: penetration 5 mm, drift 1 mm/min, |F/W - 1| 1 %; measured 1.05 mm, 2e-5 mm/min, 1e-7
    assert o["max_penetration_mm"] < 5.0
    assert o["force_balance_error"] < 0.01


def test_soft_modulus_fails_penetration(judged):
    _, by_label = judged
    o = by_label[SOFT.label]
    assert o["verdicts"]["penetration"] == "FAIL"
    assert o["max_penetration_mm"] > 100.0  # far past the 5 mm bound, not a marginal miss
    assert o["verdicts"]["convergence"] == "pass"  # it ran; it is judged on what it did
    # drift and force balance are not judged once a case has failed another criterion
    assert o["verdicts"]["drift"] == "n/a" and o["verdicts"]["force_balance"] == "n/a"


def test_coarse_step_fails_energy_and_penetration(judged):
    _, by_label = judged
    o = by_label[COARSE.label]
    assert o["verdicts"]["energy"] == "FAIL" and o["energy_gain_over_tol"] > 10.0
    assert o["verdicts"]["penetration"] == "FAIL"


def test_learned_loop_criterion_follows_modulus_and_step():
    """What stays explicit in the learned law (its normal force is linearly implicit) is the tilt
    stiffness: (h w_tilt)^2 is linear in kappa (proportional to the modulus) and in h^2. At 1 ms it
    is under the bound of 4 at 1e8 Pa and at the shipped 1e9 Pa (measured worst 3.04: windy_stack);
    twice the step at 1e9 Pa is not."""
    soft = learned_loop_stability(Setting(1e8, "similar", 0.0, 1e-3))
    shipped = learned_loop_stability(SHIPPED)
    coarse = learned_loop_stability(Setting(1e9, "similar", 0.0, 2e-3))
    assert soft["worst"] < shipped["worst"] < 4.0, (soft, shipped)
    assert shipped["worst"] == pytest.approx(10.0 * soft["worst"], rel=1e-9)  # linear in kappa
    assert coarse["worst"] == pytest.approx(4.0 * shipped["worst"], rel=1e-9) and coarse["worst"] > 4.0  # h^2


def test_toss_rows_are_judged_on_their_own_criterion():
    """A cube-toss row feeds only the toss criterion: the bound is the published Drake figure."""
    base = {"modulus": 1e9, "approximation": "similar", "margin": 0.0, "time_step": 1e-3}
    case = {**base, "case_kind": "edge_on_edge", "stable": True, "failed": "", "max_penetration_m": 0.01,
            "penetration_bound_m": 0.02, "energy_gain_J": 0.0, "energy_tolerance_J": 196.2, "wall_per_sim_s": 1.0}
    for error, verdict in ((TOSS_ERROR_BOUND * 0.9, "pass"), (TOSS_ERROR_BOUND * 1.1, "FAIL")):
        toss = {**base, "case_kind": "cube_tosses", "stable": True, "failed": "", "toss_error": error}
        (o,) = summarize([case, toss])
        assert o["verdicts"]["toss"] == verdict and o["toss_error"] == error
        assert o["cases"] == 1 and o["verdicts"]["penetration"] == "pass"  # the toss row is not a physics case
    (o,) = summarize([case])
    assert o["verdicts"]["toss"] == "n/a"


def test_solver_failure_and_timeout_are_results():
    base = {"modulus": 1e9, "approximation": "sap", "margin": 0.0, "time_step": 1e-3}
    ok = {**base, "case_kind": "edge_on_edge", "stable": True, "failed": "", "max_penetration_m": 0.01,
          "penetration_bound_m": 0.02, "energy_gain_J": 0.0, "energy_tolerance_J": 196.2, "wall_per_sim_s": 1.0}
    rows = [ok, {**base, "case_kind": "crane_edge_landing", "stable": False, "failed": "solver: no convergence"},
            {**base, "case_kind": "corner_on_face", "stable": False, "failed": "timeout"}]
    (o,) = summarize(rows)
    assert o["verdicts"]["convergence"] == "FAIL" and o["converged"] == 1 and o["cases"] == 3
    assert o["verdicts"]["penetration"] == "pass"  # judged on the case that ran
    assert any("no convergence" in f for f in o["failures"])


def test_quick_sweep_in_a_pool_renders(judged):
    rows, _ = judged
    quick = grid(quick=True)
    assert 2 <= len(quick) <= 4
    pooled = sweep(quick, ("near_parallel",), workers=2, duration=0.3)
    assert len(pooled) == len(quick) and all("error" not in r["failed"] for r in pooled)
    summary = summarize(pooled + rows)
    for o in summary:
        assert set(o["verdicts"]) == set(CRITERIA)
        assert set(o["verdicts"].values()) <= {"pass", "FAIL", "n/a"}
    json.dumps(summary, default=float)
    sections = report_sections(summary, wall_s=1.0)
    md, page = to_markdown("sweep", sections), to_html("sweep", sections)
    for o in summary:
        assert o["label"] in md and o["label"] in page


def test_cli_lists_defaults_study():
    out = subprocess.run([sys.executable, "-m", "testbed.cli", "study", "--help"], capture_output=True, text=True)
    assert "defaults" in out.stdout, out.stderr


def test_shipped_models_carry_the_chosen_modulus():
    """Every container SDF states HYDROELASTIC_MODULUS, the value the learned force law's
    stiffness and the wobble figures are computed from (one number, one place to change it)."""
    import xml.etree.ElementTree as ET
    from pathlib import Path

    from testbed.bodies.containers import CONTAINER_TYPES, HYDROELASTIC_MODULUS

    files = sorted((Path(__file__).resolve().parents[2] / "sdf" / "containers").glob("*.sdf"))
    assert len(files) == len(CONTAINER_TYPES)  # one per catalogue type
    for f in files:
        (tag,) = [e for e in ET.parse(f).iter() if e.tag.endswith("hydroelastic_modulus")]
        assert float(tag.text) == HYDROELASTIC_MODULUS, f


@pytest.mark.slow
def test_shipped_setting_passes_the_toss_criterion_on_the_shipped_tosses():
    """The toss criterion on the data shipped in the package (no skip when a folder
    beside the checkout is missing): the shipped setting's held-out error is below
    TOSS_ERROR_BOUND (13.5%, the published Drake figure); measured 12.97% (calibration README)."""
    from testbed.calibration.data import SHIPPED_TOSSES
    from testbed.studies.defaults import TOSS_CASE

    rows = sweep([SHIPPED], (TOSS_CASE,), workers=2, toss_data=SHIPPED_TOSSES)
    (row,) = [r for r in rows if r["case_kind"] == TOSS_CASE]
    assert row["tosses"] == 138 and row["stable"], row  # the held-out half of 275 (split 0.5, seed 0)
    (o,) = summarize(rows)
    assert o["verdicts"]["toss"] == "pass" and o["toss_error"] < TOSS_ERROR_BOUND, o
