"""`testbed compare`: the twin run's files, keys and exit statuses."""

import json

import numpy as np
import pytest

from testbed.cli import main

KEYS = ("position_error_max_m", "final_position_error_max_m", "final_angle_error_max_deg", "max_penetration_m",
        "energy_gain_max_J", "wall_per_sim_s_truth", "wall_per_sim_s_learned", "wall_per_sim_s_point", "diverged",
        "departed")


def test_compare_writes_figures_series_plot_and_replay(tmp_path, capsys, caplog):
    out = tmp_path / "cmp"
    assert main(["compare", "two_stack", "--duration", "0.1", "--out", str(out)]) == 0
    figures = json.loads((out / "compare.json").read_text())
    assert all(k in figures for k in KEYS)
    assert figures["diverged"] is False
    # a resting stack for 0.1 s: the learned run stays within 1 mm of Drake's (measured 0.06 mm)
    assert figures["position_error_max_m"] < 1e-3
    series = np.load(out / "trajectories.npz")
    assert series["learned_p_WB"].shape == series["truth_p_WB"].shape == (11, 2, 3)  # 10 ms records, 2 boxes
    assert (out / "divergence.png").read_bytes()[:4] == b"\x89PNG"
    replay = (out / "replay.html").read_text()
    assert "<html" in replay[:2000].lower() and "two_stack: the learned run against Drake" in replay  # its caption
    assert "learned" in capsys.readouterr().out
    assert "Meshcat listening" not in caplog.text  # the replay's server URL is gone when compare exits: not printed


@pytest.mark.parametrize("argv", [["compare", "no_such_scene"],
                                  ["compare", "two_stack", "--predictor", "/nonexistent/weights.npz"],
                                  ["compare", "two_stack", "--duration", "-1"]])
def test_bad_input_exits_2_and_writes_nothing(tmp_path, capsys, argv):
    out = tmp_path / "cmp"
    assert main(argv + ["--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("testbed: error:")
    assert not out.exists() and not list(tmp_path.iterdir())


def test_compare_predictors_shares_the_truth_run(tmp_path):
    from testbed.compare import compare_predictors

    dirs = [tmp_path / "improved", tmp_path / "paper"]
    figures = compare_predictors("two_stack", ["improved", "paper"], out_dirs=dirs, duration=0.05,
                                 with_point=False, replay=False)
    assert [f["predictor"] for f in figures] == ["improved", "paper"]
    assert figures[0]["wall_per_sim_s_truth"] == figures[1]["wall_per_sim_s_truth"]  # one truth run
    truth = [np.load(d / "trajectories.npz")["truth_p_WB"] for d in dirs]
    np.testing.assert_array_equal(truth[0], truth[1])


def test_a_bad_second_predictor_writes_nothing(tmp_path):
    from testbed.compare import compare_predictors
    from testbed.errors import ScenarioError

    with pytest.raises(ScenarioError, match="predictor"):
        compare_predictors("two_stack", ["improved", str(tmp_path / "none.npz")],
                           out_dirs=[tmp_path / "a", tmp_path / "b"], duration=0.05, replay=False)
    assert not list(tmp_path.iterdir())


def test_penetration_counts_welded_containers(tmp_path):
    """An empty 20 ft box resting on a welded one: the pair's depth is in the figures."""
    from testbed.compare import compare_scene
    from testbed.scenario import load_scenario

    text = """
name: closed_loop_on_welded
containers:
- {name: base, type: 1CC, mass: 20000.0, fixed: true, X_WC: {translation: [0.0, 0.0, 1.2955]}}
- {name: top, type: 1CC, X_WC: {translation: [0.0, 0.0, 3.8865]}}
effects: {contact: {}, friction: {}}
"""
    figures = compare_scene(load_scenario(text=text), out_dir=tmp_path / "c", duration=0.2, with_point=False,
                            replay=False)
    # static compression 2.2 t g / 6.06e8 N/m = 0.036 mm, settling overshoot < 3x (measured 0.051 mm)
    assert 2e-5 < figures["max_container_penetration_m"] < 1e-4


def test_diverged_means_failed_deep_or_energy_created():
    from testbed.compare.metrics import compare_figures
    from testbed.compare.runs import Trajectory
    from testbed.scenario import load_scenario

    scenario = load_scenario("two_stack")
    n = 5
    p = np.tile([[0.0, 0.0, 1.2955], [0.0, 0.0, 3.8865]], (n, 1, 1))
    q = np.tile([1.0, 0.0, 0.0, 0.0], (n, 2, 1))
    potential = np.full(n, 6.3e5)  # [J] about two_stack's m g z

    def traj(p, energy, error=""):
        k = len(p)
        return Trajectory(np.arange(k) * 0.01, p, q[:k], np.zeros((k, 2, 6)), energy, potential[:k], 1.0,
                          0.01 * (k - 1), error, ("bottom", "top"))

    truth = traj(p, np.zeros(n))
    same = compare_figures(truth, traj(p, np.zeros(n)), scenario.containers, None)
    assert not same["diverged"] and not same["departed"] and same["position_error_max_m"] == 0
    pumped = compare_figures(truth, traj(p, np.linspace(0, 1e4, n)), scenario.containers, None)
    assert pumped["diverged"]  # 1e4 J created > 1 % of 6.3e5 J
    away = p.copy()
    away[-1, 1, 0] = 1.0  # the top box 1 m from the truth's, no energy created
    moved = compare_figures(truth, traj(away, np.zeros(n)), scenario.containers, None)
    assert moved["departed"] and not moved["diverged"]
    assert compare_figures(truth, traj(p[:3], np.zeros(3), "boom"), scenario.containers, None)["diverged"]
