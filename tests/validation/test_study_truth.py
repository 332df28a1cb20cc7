"""The truth study (testbed.studies.truth, `testbed study truth`): the GCI on synthetic
sequences, the refined box meshes (count, volume, and Drake's contact force the same as the
Box's), one short scene through cheap rungs via the CLI, and bad input as one-line errors.
Never asserts times beyond their being positive (2 shared cores). The full ladder on the
shipped scenes is marked `study` (not run by default: pytest -m study)."""

import json
import math

import numpy as np
import pytest

from testbed.cli import main
from testbed.studies.truth import gci, mesh_refine, run as truth_run, rungs

SIZE_20FT = (6.058, 2.438, 2.591)  # [m] the 1CC container


# ----------------------------------------------------------------------------- GCI


@pytest.mark.parametrize("f_exact, C", [(1.0, 0.3), (-2.0, 0.05), (5.0, -1.0)])
def test_second_order_sequence_gives_p_2_and_a_gci_that_bounds_the_error(f_exact, C):
    h = np.array([0.25, 0.5, 1.0])  # fine, medium, coarse: r = 2
    f1, f2, f3 = f_exact + C * h**2
    result = gci.gci3(f1, f2, f3, 2.0)
    assert result["behaviour"] == "monotone"
    assert result["p"] == pytest.approx(2.0)
    assert result["fs"] == gci.FS_CONFIDENT
    assert result["gci_abs"] >= abs(f1 - f_exact)
    assert result["uncertainty"] == result["gci_abs"]
    assert result["gci_rel"] == pytest.approx(result["gci_abs"] / abs(f1))


def test_first_order_sequence_gives_p_1():
    f1, f2, f3 = (3.0 + 0.1 * h for h in (0.25, 0.5, 1.0))
    result = gci.gci3(f1, f2, f3, 2.0)
    assert result["p"] == pytest.approx(1.0) and result["fs"] == gci.FS_CONFIDENT
    assert result["gci_abs"] >= abs(f1 - 3.0)


def test_an_implausible_order_takes_the_cautious_safety_factor_and_says_so():
    f1, f2, f3 = (1.0 + 0.2 * h**4 for h in (0.25, 0.5, 1.0))  # p = 4
    result = gci.gci3(f1, f2, f3, 2.0)
    assert result["p"] == pytest.approx(4.0) and result["fs"] == gci.FS_CAUTIOUS
    assert "outside" in result["note"]


def test_an_oscillating_sequence_takes_fs_3_and_says_so():
    result = gci.gci3(0.95, 0.90, 1.00, 2.0)  # e21 = -0.05, e32 = +0.1
    assert result["behaviour"] == "oscillatory"
    assert result["fs"] == gci.FS_CAUTIOUS
    assert "oscillatory" in result["note"]
    assert result["uncertainty"] >= abs(1.00 - 0.95)  # not monotone: at least |default - reference|


def test_growing_differences_are_divergent_not_converged():
    result = gci.gci3(0.5, 0.8, 0.9, 2.0)  # |e21| = 0.3 > |e32| = 0.1, one sign
    assert result["behaviour"] == "divergent" and result["fs"] == gci.FS_CAUTIOUS
    assert result["uncertainty"] >= 0.4


def test_zero_and_missing_differences_are_stated_never_divided_by():
    same = gci.gci3(2.0, 2.0, 2.0)
    assert same["behaviour"] == "identical" and same["uncertainty"] == 0.0 and same["p"] is None
    fine = gci.gci3(2.0, 2.0, 2.5)
    assert fine["behaviour"] == "zero_fine" and fine["p"] is None and fine["uncertainty"] == pytest.approx(0.5)
    coarse = gci.gci3(2.0, 2.5, 2.5)
    assert coarse["behaviour"] == "divergent" and coarse["uncertainty"] == pytest.approx(0.5)
    at_zero = gci.gci3(0.0, 0.01, 0.05)  # f1 = 0: no relative GCI, the absolute one stands
    assert at_zero["gci_rel"] is None and at_zero["gci_abs"] > 0
    for bad in ((None, 1.0, 2.0), (math.nan, 1.0, 2.0), (1.0, math.inf, 2.0)):
        missing = gci.gci3(*bad)
        assert missing["behaviour"] == "unavailable" and missing["uncertainty"] is None


def test_two_rung_estimate_assumes_the_order_with_fs_3():
    result = gci.gci2(1.0, 1.09, r=10.0)
    assert result["behaviour"] == "two_rung" and result["fs"] == gci.FS_CAUTIOUS
    assert result["gci_abs"] == pytest.approx(3.0 * 0.09 / 9.0)
    assert gci.gci2(1.0, 1.0, r=10.0)["uncertainty"] == 0.0


# ----------------------------------------------------------------------------- meshes


def test_red_refinement_has_8x_the_tets_the_same_volume_and_keeps_drakes_vertices():
    v0, t0 = mesh_refine.drake_box_mesh(SIZE_20FT)
    assert (len(v0), len(t0)) == (18, 44)
    volume = float(np.prod(SIZE_20FT))
    assert mesh_refine.signed_volumes(v0, t0).sum() == pytest.approx(volume, rel=1e-12)
    v, t = v0, t0
    for level in (1, 2):
        v, t = mesh_refine.refine(v, t)
        vols = mesh_refine.signed_volumes(v, t)
        assert len(t) == 44 * 8**level
        assert np.all(vols > 0)  # oriented as Drake's elements
        assert vols.sum() == pytest.approx(volume, rel=1e-12)
        assert np.array_equal(v[:18], v0)  # the medial vertices (and every other original) kept
        assert len(np.unique(v.round(9), axis=0)) == len(v)  # each edge midpoint once


def _contact_force(scenario, meshes) -> np.ndarray:
    """Total contact force [N] in W on the top box, at a fixed penetrating pose, no motion."""
    from pydrake.math import RigidTransform, RollPitchYaw

    from testbed.builder import build_scene

    scene = build_scene(scenario, continuous_accuracy=1e-3, meshes=meshes)
    root = scene.diagram.CreateDefaultContext()
    context = scene.plant.GetMyMutableContextFromRoot(root)
    scene.plant.SetFreeBodyPose(context, scene.bodies["top"],
                                RigidTransform(RollPitchYaw(0.004, 0.01, 0.002), [2.9, 0.05, 3.8865 - 0.004]))
    results = scene.plant.get_contact_results_output_port().Eval(context)
    assert results.num_hydroelastic_contacts() == 1
    return np.asarray(results.hydroelastic_contact_info(0).F_Ac_W().translational())


def test_drake_gives_the_refined_meshes_the_same_contact_force_as_its_box(tmp_path):
    from testbed import variants
    from testbed.scenario import load_scenario

    scenario = variants.derive(load_scenario("overhang_hold"), variants.physics_only(learned=False))
    scenario.effects.contact_log = None
    box = _contact_force(scenario, None)
    assert abs(box[2]) > 1e5  # a real contact (about 1.8 MN at 4 mm, 1e9 Pa)
    for level in (1, 2):
        path = mesh_refine.cached_mesh_file(SIZE_20FT, level, tmp_path)
        refined = _contact_force(scenario, {SIZE_20FT: path})
        assert np.max(np.abs(refined - box)) <= 1e-8 * np.linalg.norm(box)


# ----------------------------------------------------------------------------- the command


@pytest.fixture(scope="module")
def quick_study(tmp_path_factory):
    out = tmp_path_factory.mktemp("truth")
    status = main(["study", "truth", "--quick", "--quiet", "--scenes", "overhang_hold", "--duration", "0.05",
                   "--rungs", "polygon,refined_L1,continuous", "--accuracies", "1e-2,1e-3", "--out", str(out)])
    assert status == 0
    return out, json.loads((out / "truth.json").read_text())


def test_quick_study_measures_every_rung(quick_study):
    out, study = quick_study
    assert (out / "truth.md").is_file()
    (scene,) = study["scenes"]
    assert scene["scene"] == "overhang_hold" and scene["duration_s"] == 0.05
    assert list(scene["rungs"]) == ["polygon", "refined_L1", "continuous_a1e-02", "continuous_a1e-03"]
    for row in scene["rungs"].values():
        assert row["status"] == "ok" and row["wall_s"] > 0 and row["build_s"] > 0
        assert set(row["quantities"]) >= {"top.final_x_m", "top.final_angle_deg", "peak_tilt_deg", "max_penetration_m"}
        assert all(math.isfinite(v) for v in row["quantities"].values())
    assert scene["rungs"]["continuous_a1e-03"]["time_step_s"] == 0.0


def test_quick_study_classifies_against_the_finest_rung(quick_study):
    _, study = quick_study
    (scene,) = study["scenes"]
    assert scene["reference_rung"] == "continuous_a1e-03"
    assert scene["classification"] in ("converged", "truth-sensitive")
    for q in scene["quantities"].values():
        assert q["accuracy_gci"]["behaviour"] in ("two_rung", "identical")
        assert q["mesh_gci"]["behaviour"] == "unavailable"  # no refined_L2 rung: stated, not guessed
        assert q["uncertainty"] >= q["band"] > 0 and q["default_error"] >= 0
        assert q["within"] == (q["default_error"] <= q["band"])
    assert (scene["classification"] == "converged") == (not scene["sensitive"])


def test_reference_falls_back_down_the_ladder():
    def row(kind, accuracy=None, status="ok"):
        return {"kind": kind, "accuracy": accuracy, "status": status}

    rows = {"polygon": row("polygon"), "refined_L2": row("refined_L2"), "continuous_a1e-03": row("continuous", 1e-3, "failed")}
    assert truth_run.reference_rung(rows) == "refined_L2"
    assert truth_run.reference_rung({"polygon": row("polygon")}) is None
    assert [r[0] for r in rungs.expand(("continuous", "polygon"), (1e-4, 1e-3))] == \
        ["polygon", "continuous_a1e-03", "continuous_a1e-04"]


def test_a_rung_drake_refuses_is_kept_as_failed_not_raised(tmp_path):
    """The crane's force output reads the contact results: on a continuous plant that is an
    algebraic loop, which Drake refuses at build time; the rung says so and the study goes on."""
    from testbed.scenario import load_scenario

    base = rungs.base_scenario(load_scenario("crane_hard_landing"), 0.01)
    row = rungs.run_rung("continuous_a1e-03", "continuous", base, accuracy=1e-3, cache_dir=tmp_path)
    assert row["status"] == "failed" and "algebraic loop" in row["error"] and row["quantities"] == {}
    assert truth_run.analyze({"polygon": {**row, "rung": "polygon", "kind": "polygon", "status": "failed"},
                              "continuous_a1e-03": row})["classification"] == "unclassified"


@pytest.mark.parametrize("argv, words", [
    (["--rungs", "polygon,bogus"], "--rungs"),
    (["--accuracies", "1e-3,2"], "--accuracies"),
    (["--duration", "-1"], "--duration"),
    (["--scenes", "no_such_scene_here"], "no_such_scene_here"),
])
def test_bad_input_is_one_line_and_exit_2_with_nothing_written(tmp_path, capsys, argv, words):
    out = tmp_path / "out"
    assert main(["study", "truth", "--quick", "--quiet", "--out", str(out), *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and words in err
    assert not out.exists()


def test_a_bad_scene_file_is_one_line_and_exit_2(tmp_path, capsys):
    scene = tmp_path / "bad.yaml"
    scene.write_text("name: bad\ncontainers:\n- name: a\n  type: 1CC\n  mass: -5\n")
    assert main(["study", "truth", "--quiet", "--scenes", str(scene), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "mass" in err
    assert not (tmp_path / "out").exists()


@pytest.mark.study
def test_full_ladder_on_the_shipped_scenes(tmp_path):
    """Every rung of every default scene at its gate duration (tens of minutes on 2 cores)."""
    assert main(["study", "truth", "--quiet", "--out", str(tmp_path)]) == 0
    study = json.loads((tmp_path / "truth.json").read_text())
    assert [s["scene"] for s in study["scenes"]] == list(truth_run.FULL_SCENES)
    for scene in study["scenes"]:
        assert scene["classification"] in ("converged", "truth-sensitive")
