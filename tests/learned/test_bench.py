"""`testbed bench` and `testbed validate --predictor`: any model judged beside the shipped
ones, by the same sections. The crude centre-line ONNX model and the geometric prior (a
Python object) are the models the bench must rank below the shipped predictor."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("onnxruntime", reason="pip install onnxruntime==1.30.0")

import bench_models as bm  # noqa: E402

TESTS = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def centre_line(tmp_path_factory):
    return str(bm.centre_line_onnx(tmp_path_factory.mktemp("models") / "centre_line.onnx"))


@pytest.fixture(scope="module")
def quick_bench(centre_line, tmp_path_factory):
    from testbed.bench import bench

    out = tmp_path_factory.mktemp("bench") / "out"
    return bench(["improved", centre_line, "bench_models:GeometricModel"], quick=True, out_dir=out, references=False,
                 progress=False), out


def test_bench_judges_every_predictor_the_same_way(quick_bench, centre_line):
    data, out = quick_bench
    specs = ["improved", centre_line, "bench_models:GeometricModel"]
    assert sorted(data["leaderboard"]) == sorted(specs)
    for spec in specs:
        e = data["predictors"][spec]
        assert set(e) >= {"accuracy", "cost", "in_scene", "closed_loop", "verdict", "good_enough"}
        assert set(e["accuracy"]["sets"]) == {"stacking", "general", "outside", "resting", "resting_wider",
                                                 "resting_wider_level"}
        assert e["accuracy"]["gates_total"] == len(e["accuracy"]["gates"]) > 0
        assert set(e["closed_loop"]) == {"two_stack", "crane_misaligned", "overhang_tip"}
        assert e["cost"]["batched_s_per_pair"] > 0 and e["cost"]["first_call_s"] > 0
        assert e["verdict"].startswith("GOOD ENOUGH" if e["good_enough"] else "NOT GOOD ENOUGH")
    # the yard budget: pairs answered within a 1 ms step beside the host's measured step
    budget = data["yard_budget"]
    assert set(budget["predictors"]) == set(specs) and budget["host"]["host_step_s"] > 0
    assert all(b.get("pairs_within_step") is not None or b.get("why") for b in budget["predictors"].values())
    assert "## Yard budget" in (out / "summary.md").read_text()
    # the shipped predictor beats both simple alternatives on held-out stacking poses, and
    # the prior is its own reference (ratio 1 by construction)
    improved, line = data["predictors"]["improved"], data["predictors"][centre_line]
    geo = data["predictors"]["bench_models:GeometricModel"]
    assert improved["accuracy"]["sets"]["stacking"]["point_median_m"] < 0.65 * geo["accuracy"]["sets"]["stacking"]["point_median_m"]
    assert line["accuracy"]["sets"]["stacking"]["point_median_m"] > 10 * improved["accuracy"]["sets"]["stacking"]["point_median_m"]
    assert geo["accuracy"]["sets"]["general"]["point_p95_m_vs_prior"] == pytest.approx(1.0, abs=1e-9)
    assert line["accuracy"]["gates_passed"] < line["accuracy"]["gates_total"] and not line["good_enough"]
    # the shipped predictor meets the resting and wider resting targets as plain gates (the exact
    # face-on-face closed form), which the geometric prior fails; one target is pinned (the outside
    # set's p95 against the prior), so the verdict says it ("GOOD ENOUGH WITHIN 1 KNOWN LIMITS")
    mine = {g["name"]: g["passed"] for g in improved["accuracy"]["gates"]}
    prior = {g["name"]: g["passed"] for g in geo["accuracy"]["gates"]}
    for name in ("resting point error median", "resting point error p95", "resting_wider point error p95",
                 "stacking point error median"):
        assert mine[name] and not prior[name]
    assert improved["known_limits"] == ["outside point error p95 vs prior (known limit)"]
    assert improved["good_enough"] and improved["verdict"].startswith("GOOD ENOUGH WITHIN 1 KNOWN LIMITS: accuracy gates")
    assert data["leaderboard"].index("improved") < data["leaderboard"].index(centre_line)
    # in the loop, against overhang_tip's converged truth (the continuous plant) the geometric prior
    # follows it as closely as the shipped predictor (it is a linear foundation's exact integral: 0.020
    # deg, measured; 0.74 deg against the discrete truth before 0.6.0); the centre line does not
    assert improved["closed_loop"]["overhang_tip"]["passed"] and geo["closed_loop"]["overhang_tip"]["passed"]
    # the files hold the same data; every predictor is in the leaderboard table
    assert set(data["provenance"]) == {"date", "commit", "machine", "python", "drake"}
    # what an integrator pays: an external model alone (its own answer function) beside the wrapped call
    assert line["cost"]["model_single_s_per_pair"] > 0 and line["cost"]["model_batched_s_per_pair"] > 0
    assert "model_single_s_per_pair" not in improved["cost"]  # the shipped predictor has no wrapper
    assert all(f["cost_learned"]["predictor_us_per_step"] > 0 for f in improved["closed_loop"].values())
    on_disk = json.loads((out / "bench.json").read_text())
    assert on_disk["leaderboard"] == data["leaderboard"]
    html = (out / "index.html").read_text()
    assert all(label in html for label in ("improved", "centre_line", "GeometricModel")) and "data:image/png;base64" in html


def test_the_headline_speaks_of_the_models_the_user_named(quick_bench, centre_line):
    """The shipped model passing does not make the headline pass: it is a reference line, the
    headline and the exit status judge the user's models (both fail here)."""
    from testbed.bench.report import headline

    data, out = quick_bench
    assert data["judged"] == [centre_line, "bench_models:GeometricModel"]
    good, lines = headline(data)
    assert not good and data["predictors"]["improved"]["good_enough"]
    assert lines[0].startswith("centre_line: NOT GOOD ENOUGH") and lines[-1].startswith("reference improved: GOOD ENOUGH")
    assert "gates 21 of 21 passed" in data["predictors"]["improved"]["verdict"]


def test_a_model_is_judged_on_the_container_sizes_it_declares():
    from testbed.bench.accuracy import covered, pose_sets
    from testbed.bench.run import uncovered

    model = bm.FortyFootOnly()
    data = pose_sets(0, 60, workers=1)
    kept, counts = covered(model, data)
    for name, (n_kept, n_all) in counts.items():
        assert 0 < n_kept < n_all, (name, counts)  # the held-out sets mix 20 ft and 40 ft boxes
        sizes = np.vstack([kept[name].size_A, kept[name].size_B])
        assert np.all(sizes[:, 0] > 12.0)  # only 40 ft boxes are asked
    assert uncovered(model, "two_stack") == ("two_stack: container 'bottom' (type 1CC, size (6.058, 2.438, 2.591) m) "
                                             "is not a size the model declares")
    assert uncovered(model, "windy_stack") is None  # two 40 ft boxes


def test_a_scene_with_a_size_the_model_does_not_declare_is_named_at_build():
    from testbed.errors import ScenarioError
    from testbed.scenario import load_scenario

    with pytest.raises(ScenarioError, match="containers\\[0\\]: 'tier1' \\(type 1CC") as info:
        load_scenario("five_stack", overrides=["effects.learned_dynamics={predictor: 'bench_models:FortyFootOnly'}"])
    assert "five_stack.yaml" in str(info.value) and "bench_models:FortyFootOnly declares" in str(info.value)


def test_bench_cli_refuses_a_bad_model_with_nothing_written(tmp_path):
    bad = bm.centre_line_onnx(tmp_path / "bad.onnx", input_names=("p", "R_AB", "size_A", "size_B"))
    out = tmp_path / "out"
    proc = subprocess.run([sys.executable, "-m", "testbed.cli", "bench", "improved", str(bad), "--quick", "--out",
                           str(out)], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 2 and str(bad) in proc.stderr and "p_AB" in proc.stderr
    assert not out.exists()


def test_validate_predictor_is_reported_beside_the_shipped_ones_not_gated(tmp_path, centre_line):
    from testbed.validation import validate

    run_dir, metrics = validate(suite_name="smoke", workers=1, out_root=tmp_path, progress=False, replays=0,
                                predictors=[centre_line])
    record = json.loads((run_dir / "cases" / "closed-two_stack.json").read_text())
    assert centre_line in record["result"]["predictors"]  # ran against the same truth run
    assert not any("centre_line" in g["name"] for g in metrics["gates"])  # reported, not gated
    assert "centre_line (reported, not gated)" in (run_dir / "summary.md").read_text()


def test_validate_refuses_a_bad_predictor_before_anything_runs(tmp_path):
    from learned_contact import WeightsError
    from testbed.validation import validate

    with pytest.raises(WeightsError, match="static batch axis"):
        validate(suite_name="smoke", out_root=tmp_path / "runs", progress=False,
                 predictors=[str(bm.centre_line_onnx(tmp_path / "bad.onnx", static_batch=3))])
    assert not (tmp_path / "runs").exists() or not any((tmp_path / "runs").iterdir())


def test_learned_gates_case_reports_an_added_predictor(centre_line):
    from testbed.validation.cases import Case
    from testbed.validation.cases.learned_gates import LearnedGatesCase

    kind = LearnedGatesCase()
    cases = kind.with_predictors([Case("learned-gates", "learned_gates", {"seed": 0})], [centre_line])
    assert [c.id for c in cases] == ["learned-gates", "learned-gates-centre_line"]
    record = {"id": cases[1].id, "result": kind.run(**cases[1].params)}
    assert kind.gates(record) == []  # not gated
    assert not all(g["passed"] for g in record["result"]["gates"])  # and it fails them on the data
    sections = kind.sections([record])
    assert sections and "centre_line" in sections[0].blocks[1].headers


def test_query_study_times_an_added_predictor(centre_line):
    from learned_contact.evaluation.gates import held_out
    from testbed.studies.query.methods.base import MethodOptions
    from testbed.studies.query.methods.learned import build

    ds = held_out(0, 20)["stacking"]
    methods = build(ds, None, MethodOptions(extra_predictors=(centre_line,)))
    mine = {m.name: m for m in methods if m.name.startswith("bench_centre_line")}
    assert set(mine) == {"bench_centre_line_single", "bench_centre_line_batched"} and all(m.available for m in mine.values())
    point, normal = mine["bench_centre_line_batched"].batched()
    np.testing.assert_allclose(point, 0.5 * ds.p_AB, atol=1e-6)


def test_compare_runs_an_onnx_predictor(tmp_path, centre_line):
    out = tmp_path / "cmp"
    proc = subprocess.run([sys.executable, "-m", "testbed.cli", "compare", "two_stack", "--predictor", centre_line,
                           "--duration", "0.05", "--out", str(out), "--no-replay"], capture_output=True, text=True,
                          timeout=600)
    # it runs; the crude centre-line model may fail a closed-loop gate (exit 3: it creates energy on two_stack)
    assert proc.returncode in (0, 3), proc.stderr
    figures = json.loads((out / "compare.json").read_text())
    assert figures["predictor"] == centre_line and figures["predictor_kind"] == "onnx"
    assert figures["exit_status"] == proc.returncode and not figures["diverged"]
