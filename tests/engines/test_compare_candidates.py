"""compare_candidates (testbed/compare/run_candidates.py): one reference run for every
candidate, each learned candidate judged by the closed-loop gates, compare.json written once;
and `testbed compare --no-truth`, which times the candidates without any Drake truth run."""

import json

import numpy as np
import pytest

from testbed.compare import Candidate, compare_candidates, run_candidates as rc
from testbed.compare.verdict import judge
from testbed.scenario import load_scenario


def test_one_reference_run_for_every_candidate(tmp_path, monkeypatch):
    calls = []
    real = rc.reference_run
    monkeypatch.setattr(rc, "reference_run", lambda *a, **k: calls.append(1) or real(*a, **k))
    chosen = [Candidate("learned", predictor="improved"), Candidate("learned", predictor="paper"), Candidate.point()]
    f = compare_candidates(load_scenario("two_stack"), chosen, duration=0.05, out_dir=tmp_path / "c", judge=judge)
    assert len(calls) == 1
    assert list(f["candidates"]) == ["learned (improved)", "learned (paper)", "Drake point"]
    assert f["primary"] == "learned (improved)" and f["predictor"] == "improved"
    walls = {c["wall_per_sim_s_truth"] for c in f["candidates"].values()}
    assert walls == {f["wall_per_sim_s_truth"]}  # one truth run's wall time in every candidate's figures
    for label in ("learned (improved)", "learned (paper)"):  # judged: a verdict and the series the gates read
        assert f["candidates"][label]["verdict"] in ("PASS", "FAIL", "DIVERGED")
        with np.load(tmp_path / "c" / "judged" / rc.slug(label) / "trajectories.npz") as d:
            assert d["learned_p_WB"].shape == d["truth_p_WB"].shape == (6, 2, 3)  # 10 ms records, 2 boxes
    assert "verdict" not in f["candidates"]["Drake point"]
    # a resting stack for 0.05 s: Drake point within 2 mm of Drake hydroelastic (measured 1.1 mm
    # at 0.3 s, compare --engine all on two_stack), and the point run is its own speed reference
    point = f["candidates"]["Drake point"]
    assert point["position_error_max_m"] < 2e-3 and point["speedup_vs_point"] == 1.0
    saved = json.loads((tmp_path / "c" / "compare.json").read_text())
    assert saved["verdict"] == f["verdict"] and saved["table"]["rows"][2]["model"] == "Drake point"


def test_no_truth_times_the_candidates_without_drake(tmp_path, monkeypatch, capsys):
    from testbed.cli import main

    def no_drake(*args, **kwargs):
        raise AssertionError("the reference ran under --no-truth")

    monkeypatch.setattr(rc, "reference_run", no_drake)
    out = tmp_path / "cmp"
    assert main(["compare", "two_stack", "--no-truth", "--duration", "0.05", "--no-replay", "--out", str(out)]) == 0
    f = json.loads((out / "compare.json").read_text())
    assert f["verdict"] == rc.NO_REFERENCE and f["exit_status"] == 0
    assert list(f["candidates"]) == ["learned (improved)"]  # Drake point left out: no Drake run at all
    c = f["candidates"]["learned (improved)"]
    assert c["simulated_s"] == pytest.approx(0.05) and c["error"] == "" and c["wall_per_sim_s"] > 0
    assert "wall_per_sim_s_truth" not in f and "gates" not in f
    with np.load(out / "trajectories.npz") as z:  # the records carry the names docs/commands.md lists
        free = [c.name for c in load_scenario("two_stack").containers if not c.fixed]
        assert list(z["names"]) == free and z["learned_improved_p_WB"].shape[1] == len(free)
    printed = capsys.readouterr().out.strip().splitlines()
    assert printed[-1] == f"verdict: {rc.NO_REFERENCE} (exit status 0)"
    timed = next(line for line in printed if line.strip().startswith("learned (improved):"))
    assert f"real-time factor {1.0 / c['wall_per_sim_s']:.2f}x" in timed and "t = 0-0.05 s" in timed


def test_no_truth_checks_the_scene_as_run_does(tmp_path, monkeypatch):
    """A load starting 0.6 m inside the box below: `testbed run` refuses it (exit 2), and so does
    compare --no-truth, before any candidate runs (it ran with exit 0 before)."""
    from testbed.cli import main

    monkeypatch.setattr(rc, "compare_candidates", lambda *a, **k: (_ for _ in ()).throw(AssertionError("ran")))
    overlap = ["--set", "containers[1].X_WC.translation=[0, 0, 3.3]"]
    assert main(["run", "two_stack", *overlap, "--duration", "0.01", "--out", str(tmp_path / "r")]) == 2
    for engine in ("learned", "mujoco_learned"):
        assert main(["compare", "two_stack", *overlap, "--no-truth", "--engine", engine, "--no-replay",
                     "--out", str(tmp_path / engine)]) == 2, engine
        assert not (tmp_path / engine).exists()


def test_a_learned_candidate_needs_a_learned_engine():
    with pytest.raises(ValueError, match="a predictor applies only to a learned engine"):
        Candidate("drake", params="point", predictor="improved")
    with pytest.raises(ValueError, match="labels must be unique"):
        rc.run_scenes(load_scenario("two_stack"), [Candidate.point(), Candidate.point()])


def test_the_scenes_learned_dynamics_config_reaches_the_learned_candidate_only(tmp_path):
    """A scene that declares learned_dynamics (here the paper predictor, dissipation 7 s/m): the
    learned loop runs that config, the truth and Drake point run without the learned loop (their
    figures and the loop's differ), and no predictor is named for Drake point."""
    scenario = load_scenario("two_stack", overrides=["effects.learned_dynamics={predictor: paper, dissipation: 7.0}"])
    from testbed.compare import compare_scene

    f = compare_scene(scenario, out_dir=tmp_path / "c", duration=0.05, replay=False)
    assert f["predictor"] == "paper" and f["primary"] == "learned (paper)"
    assert f["learned_dynamics_config"]["dissipation"] == 7.0
    assert "predictor" not in f["candidates"]["Drake point"]
    # Drake point is Drake's own contact, not the loop: its run differs from the learned one
    assert f["candidates"]["Drake point"]["position_error_max_m"] != f["position_error_max_m"]
