"""`testbed calibrate`: toss files, the velocity frame, the free-flight initial state, the
split, a fit that recovers known parameters, and the command's output (the shipped
parameter files: test_calibration_shipped.py).

Tolerances (and why) are stated at each assertion.
"""

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
from pydrake.common.eigen_geometry import Quaternion
from pydrake.math import RollPitchYaw, RotationMatrix

from testbed.calibration.data import CUBE_WIDTH, SHIPPED_TOSSES, CalibrationDataError, Toss, load_tosses, save_tosses
from testbed.calibration.evaluate import RolloutPool
from testbed.calibration.fit import FreeParameter, fit
from testbed.calibration.initial_state import first_frame, flight_fit
from testbed.calibration.params_file import from_fragment, to_fragment
from testbed.calibration.rollout import CubeTossParams, TossSimulator, initial_velocity
from testbed.calibration.split import duplicate_groups, train_test_split
from testbed.cli import main
from testbed.drake_support import has_tamsi
from testbed.errors import TestbedError
from testbed.physics import GRAVITY

DT = 1.0 / 148.0  # [s] the data's frame period
CALIBRATION_DIR = Path(__file__).resolve().parents[2] / "testbed" / "calibration"
DATA = SHIPPED_TOSSES  # the even-numbered DAIR Lab tosses shipped in the package


def _synthetic_toss(toss_id, p0, rpy_deg, w_B, v, n):
    """A toss with only its first frame meaningful (positions filled by the rollout later)."""
    q0 = RotationMatrix(RollPitchYaw(np.radians(rpy_deg))).ToQuaternion().wxyz()
    t = np.arange(n) * DT
    return Toss(toss_id, t, np.tile(q0, (n, 1)), np.tile(np.asarray(p0, float), (n, 1)),
                np.tile(np.asarray(w_B, float), (n, 1)), np.tile(np.asarray(v, float), (n, 1)))


def _simulated(tosses, params):
    """The tosses with poses replaced by a rollout with `params` ("data" from known parameters)."""
    sim = TossSimulator(params, DT)
    out = []
    for toss in tosses:
        p, q = sim.rollout(toss)
        out.append(dataclasses.replace(toss, p_WB=p, q_WB=q))
    return out


# ----------------------------------------------------------------------------- data loader


def _write(path, **arrays):
    good = {"states": np.tile([1.0, 0, 0, 0, 0, 0, 0.2, 0, 0, 0, 0, 0, 0], (10, 1)),
            "offsets": np.array([0, 4, 10]), "toss_id": np.array([0, 2]), "dt": np.array(DT)}
    good.update(arrays)
    np.savez(path, **{k: v for k, v in good.items() if v is not None})
    return path


def test_loader_reads_a_good_file(tmp_path):
    data = load_tosses(_write(tmp_path / "good.npz"))
    assert [len(t) for t in data.tosses] == [4, 6]
    assert data.tosses[1].toss_id == 2 and data.dt == pytest.approx(DT)


@pytest.mark.parametrize("arrays,field", [
    ({"offsets": None}, "offsets"),
    ({"dt": None}, "dt"),
    ({"states": np.zeros((10, 12))}, "states"),
    ({"states": np.zeros((10, 13, 1))}, "states"),
    ({"offsets": np.array([0, 4, 11])}, "offsets"),
    ({"offsets": np.array([0, 7, 4, 10]), "toss_id": np.array([0, 1, 2])}, "offsets"),
    ({"offsets": np.array([1, 4, 10])}, "offsets"),
    ({"toss_id": np.array([0, 1, 2])}, "toss_id"),
    ({"dt": np.array(-1.0)}, "dt"),
    ({"states": np.zeros((10, 13))}, "states[:, 0:4]"),  # zero quaternions
])
def test_loader_bad_files_name_file_field_and_expectation(tmp_path, arrays, field):
    path = _write(tmp_path / "bad.npz", **arrays)
    with pytest.raises(CalibrationDataError) as info:
        load_tosses(path)
    assert info.value.field == field
    assert str(path) in str(info.value) and "expected" in str(info.value)


def test_loader_rejects_a_file_that_is_not_npz(tmp_path):
    path = tmp_path / "junk.npz"
    path.write_text("not a zip")
    with pytest.raises(CalibrationDataError, match="not a readable .npz"):
        load_tosses(path)


# ----------------------------------------------------------------------------- velocity frame


def test_body_angular_velocity_is_rotated_to_world():
    # body x spins at 2 rad/s; the body is yawed 90 degrees, so its x axis is world y
    toss = _synthetic_toss(0, [0, 0, 1], [0, 0, 90], [2.0, 0, 0], [0.1, 0, 0], 2)
    w_W, v_W = initial_velocity(toss)
    assert np.allclose(w_W, [0, 2.0, 0], atol=1e-12)  # exact rotation, rounding only
    assert np.allclose(v_W, [0.1, 0, 0])


def test_free_flight_rollout_matches_the_analytic_spinning_cube():
    """A tilted cube spinning about a body axis, far above the table: with equal principal
    moments the world angular velocity is constant, so R_WB(t) = exp(t [w_W]) R_WB(0) and
    p(t) is a parabola. Agreement to 1e-6 m / 1e-3 deg (the discrete step is exact for
    constant w and gravity up to rounding) proves w_B was rotated into W."""
    toss = _synthetic_toss(0, [0, 0, 5.0], [30, -20, 50], [3.0, -1.0, 2.0], [0.5, 0.2, 1.0], 30)
    p, q = TossSimulator(CubeTossParams(), DT).rollout(toss)
    w_W, v = initial_velocity(toss)
    R0 = RotationMatrix(Quaternion(toss.q_WB[0]))
    for k in (10, 29):
        t = toss.t[k]
        axis = w_W / np.linalg.norm(w_W)
        from pydrake.common.eigen_geometry import AngleAxis

        R = RotationMatrix(AngleAxis(np.linalg.norm(w_W) * t, axis)).multiply(R0)
        angle = np.degrees(R.inverse().multiply(RotationMatrix(Quaternion(q[k]))).ToAngleAxis().angle())
        assert angle < 1e-3
        expected = toss.p_WB[0] + v * t + 0.5 * np.array([0, 0, -GRAVITY]) * t**2
        # semi-implicit Euler drops h g t / 2 per unit time: bounded by 0.5 * h * g * t
        assert np.linalg.norm(p[k] - expected) < 0.5 * 1e-3 * GRAVITY * t + 1e-9


def _noisy_flight(sigma_p, sigma_r, n, seed=1):
    """A free-flight toss sampled from the exact motion (parabola; constant w_W, equal
    principal moments) with Gaussian mocap-like noise: sigma_p [m] on positions, sigma_r [rad]
    rotation vectors on orientations; stored velocities are backward differences of the
    noisy frames, as in the data. Returns (toss, (R0, p0, w_W, v0) of the truth)."""
    from pydrake.common.eigen_geometry import AngleAxis

    rng = np.random.default_rng(seed)
    p0, v0, w_W = np.array([0.1, -0.2, 0.6]), np.array([1.1, 0.3, -0.4]), np.array([2.0, -3.0, 1.0])
    R0 = RotationMatrix(RollPitchYaw(np.radians([20, -35, 60])))
    t_all = np.arange(-1, n) * DT  # one frame before the first, for the first backward difference
    p_all = p0 + np.outer(t_all, v0) - 0.5 * GRAVITY * np.outer(t_all**2, [0, 0, 1]) + rng.normal(0, sigma_p, (n + 1, 3))
    t, p, v = t_all[1:], p_all[1:], np.diff(p_all, axis=0) / DT
    q, R = [], []
    for k in range(n):
        noise = rng.normal(0, sigma_r, 3)
        R_true = RotationMatrix(AngleAxis(np.linalg.norm(w_W) * t[k], w_W / np.linalg.norm(w_W))).multiply(R0)
        R_k = RotationMatrix(AngleAxis(np.linalg.norm(noise), noise / np.linalg.norm(noise))).multiply(R_true)
        q.append(R_k.ToQuaternion().wxyz())
        R.append(R_k.matrix())
    w_B = np.array([Rk.T @ w_W for Rk in R])  # stored body-frame angular velocity (noise-free, like a good gyro)
    return Toss(0, t, np.array(q), p, w_B, v), (R0, p0, w_W, v0)


def test_flight_fit_recovers_the_initial_state_from_noisy_frames():
    """20 flight frames with 1 mm / 10 mrad noise. Least-squares standard deviations
    (n = 20, frame times 0..19 dt): intercept sigma_p * 0.43 = 0.43 mm, slope
    sigma_p / (dt * 25.8) = 5.7 mm/s, angular slope sigma_r / (dt * 25.8) = 0.057 rad/s,
    so the bounds below (2.5 mm, 0.03 m/s, 0.3 rad/s, 15 mrad) are about 5 sigma; the
    first frame's backward-difference velocity is off by sqrt(2) sigma_p / dt ~ 0.2 m/s."""
    toss, (R0, p0, w_W, v0) = _noisy_flight(1e-3, 1e-2, 20)
    R, p, w, v = flight_fit(toss, table_height=-1.0)  # table 1 m below: every frame is free flight
    assert np.linalg.norm(p - p0) < 2.5e-3
    assert np.linalg.norm(v - v0) < 0.03
    assert np.linalg.norm(w - w_W) < 0.3
    assert R.inverse().multiply(R0).ToAngleAxis().angle() < 15e-3
    _, _, _, v_first = first_frame(toss)
    assert np.linalg.norm(v - v0) < np.linalg.norm(v_first - v0)  # the point of the fit


def test_flight_fit_keeps_the_first_frame_when_the_toss_starts_at_the_table():
    toss, _ = _noisy_flight(1e-3, 1e-2, 20)
    R, p, w, v = flight_fit(toss, table_height=0.6)  # table at the cube's height: no free-flight frame
    R_f, p_f, w_f, v_f = first_frame(toss)
    assert np.array_equal(p, p_f) and np.array_equal(v, v_f) and np.array_equal(w, w_f)
    assert np.array_equal(R.matrix(), R_f.matrix())


# ----------------------------------------------------------------------------- split


def _rotated_copy(toss, toss_id, yaw_deg):
    R = RotationMatrix.MakeZRotation(np.radians(yaw_deg))
    q = np.array([(R.multiply(RotationMatrix(Quaternion(qi)))).ToQuaternion().wxyz() for qi in toss.q_WB])
    return dataclasses.replace(toss, toss_id=toss_id, p_WB=toss.p_WB @ R.matrix().T, q_WB=q)


def test_split_keeps_duplicates_on_the_same_side():
    rng = np.random.default_rng(3)
    tosses = []
    for i in range(30):
        n = 20 + i % 3
        p = np.column_stack([rng.normal(size=n), rng.normal(size=n), 0.3 + 0.01 * rng.normal(size=n)])
        tosses.append(Toss(i, np.arange(n) * DT, np.tile([1.0, 0, 0, 0], (n, 1)), p, np.zeros((n, 3)), np.zeros((n, 3))))
    tosses += [_rotated_copy(tosses[i], 100 + i, 90 + 10 * i) for i in (0, 5, 7, 20)]
    groups = [g for g in duplicate_groups(tosses) if len(g) > 1]
    assert sorted(groups) == [[0, 30], [5, 31], [7, 32], [20, 33]]
    for seed in range(20):
        train, test = train_test_split(tosses, 0.5, seed)
        assert sorted(train + test) == list(range(len(tosses)))
        for a, b in groups:
            assert (a in test) == (b in test)


def test_split_of_the_real_data_keeps_its_duplicates_together():
    data = load_tosses(DATA)
    groups = [g for g in duplicate_groups(data.tosses) if len(g) > 1]
    assert len(groups) >= 1  # the even half holds 6 duplicated pairs
    train, test = train_test_split(data.tosses, 0.5, 0)
    for g in groups:
        assert len({i in test for i in g}) == 1


# ----------------------------------------------------------------------------- fit


def _toss_set_like(tosses, tmp_path):
    path = save_tosses(tmp_path / "sim.npz", tosses, DT)
    return load_tosses(path)


def test_fit_recovers_known_friction_and_stiffness(tmp_path):
    """Trajectories simulated with mu = 0.3, k = 1e5 N/m; the fit starts at mu = 0.45,
    k = 1e4 and must return within 0.02 in mu (the sharp valley is ~0.05 wide) and a factor
    1.5 in k (stiffness shows only in bounce height and penetration: a weaker signal)."""
    truth = CubeTossParams(model="point", mu=0.3, point_contact_stiffness=1e5, relaxation_time=1e-3)
    starts = [([0, 0, 0.15], [10, 20, 0], [4, 1, 0], [1.0, 0.2, -0.5]),
              ([0, 0, 0.12], [0, 35, 15], [-2, 3, 1], [0.6, -0.8, 0.0]),
              ([0, 0, 0.2], [45, 0, 30], [0, 0, 6], [-0.9, 0.4, -1.0])]
    tosses = _simulated([_synthetic_toss(i, *s, n=60) for i, s in enumerate(starts)], truth)
    data = _toss_set_like(tosses, tmp_path)
    free = [FreeParameter("mu", 0.1, 0.6, False), FreeParameter("point_contact_stiffness", 3.0, 6.0, True)]
    start = dataclasses.replace(truth, mu=0.45, point_contact_stiffness=1e4)
    with RolloutPool(data, 1) as pool:
        result = fit(pool, start, list(range(len(tosses))), free=free, max_evaluations=80)
    assert abs(result.params.mu - 0.3) < 0.02
    assert 1 / 1.5 < result.params.point_contact_stiffness / 1e5 < 1.5
    assert result.train_error < 0.01  # a percent of a cube width: the data are the model's own


# ----------------------------------------------------------------------------- command


def _small_file(tmp_path):
    truth = CubeTossParams(model="point", mu=0.3, point_contact_stiffness=1e5)
    starts = [([0, 0, 0.15], [10, 20, 0], [4, 1, 0], [1.0, 0.2, -0.5]),
              ([0, 0, 0.12], [0, 35, 15], [-2, 3, 1], [0.6, -0.8, 0.0])]
    tosses = _simulated([_synthetic_toss(i, *s, n=40) for i, s in enumerate(starts)], truth)
    return save_tosses(tmp_path / "few.npz", tosses, DT), truth


def test_params_file_round_trips_and_is_a_scene(tmp_path):
    from testbed.builder import build_scene
    from testbed.scenario import load_scenario

    # TAMSI (no default value) where the installed Drake has it, else lagged (Drake >= 1.57)
    params = CubeTossParams(model="point", approximation="tamsi" if has_tamsi() else "lagged", mu=0.21, point_contact_stiffness=3e5, relaxation_time=2e-3,
                            table_height=-0.001, corner_spheres=1e-3, time_step=DT / 14, stiction_tolerance=2e-3)
    path = tmp_path / "params.yaml"
    path.write_text(to_fragment(params, "a comment"))
    assert from_fragment(path) == params
    scene = build_scene(load_scenario(path))
    assert "cube" in scene.body_names


def test_tamsi_params_check_against_the_installed_drake(tmp_path, capsys):
    """approximation: tamsi is valid up to Drake 1.56; from 1.57 (no TAMSI) the parameters, the
    params file and `calibrate fit --approximation tamsi` fail with one line naming the version."""
    params = CubeTossParams(model="point", approximation="tamsi")
    if has_tamsi():
        params.check()
        return
    with pytest.raises(TestbedError, match=r"^approximation: 'tamsi' is not available in the installed Drake 1\."):
        params.check()
    data, _ = _small_file(tmp_path)
    assert main(["calibrate", "fit", "--data", str(data), "--out", str(tmp_path / "fit"), "--approximation", "tamsi",
                 "--workers", "1", "--budget", "1"]) == 2
    assert "'tamsi' is not available in the installed Drake" in capsys.readouterr().err


def test_calibrate_evaluate_writes_the_metrics(tmp_path):
    data, truth = _small_file(tmp_path)
    params = tmp_path / "params.yaml"
    params.write_text(to_fragment(truth))
    out = tmp_path / "eval"
    assert main(["calibrate", "evaluate", "--data", str(data), "--params", str(params), "--out", str(out), "--workers", "1"]) == 0
    metrics = json.loads((out / "metrics.json").read_text())
    for key in ("position_error_mean", "position_error_median", "rotation_error_mean_deg", "n_trajectories", "wall_s"):
        assert key in metrics
    assert metrics["n_trajectories"] == 2
    assert metrics["position_error_mean"] < 1e-9  # the file was simulated with these parameters: same code, same numbers
    assert (out / "per_toss.csv").exists() and (out / "error_per_toss.png").exists()


def test_calibrate_fit_writes_params_and_held_out_metrics(tmp_path):
    data, _ = _small_file(tmp_path)
    out = tmp_path / "fit"
    assert main(["calibrate", "fit", "--data", str(data), "--out", str(out), "--workers", "1", "--budget", "3",
                 "--split", "0.5", "--time-step", "1e-3"]) == 0
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["train"]["n_trajectories"] == 1 and metrics["test"]["n_trajectories"] == 1
    assert from_fragment(out / "params.yaml").model == "point"


@pytest.mark.parametrize("content", [b"not a zip", None])
def test_calibrate_exits_2_on_a_bad_file(tmp_path, capsys, content):
    bad = tmp_path / "bad.npz"
    if content is not None:
        bad.write_bytes(content)
    params = tmp_path / "params.yaml"
    params.write_text(to_fragment(CubeTossParams()))
    out = tmp_path / "out"
    assert main(["calibrate", "evaluate", "--data", str(bad), "--params", str(params), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(bad) in err
    assert not out.exists()  # nothing half-written


@pytest.mark.parametrize("split", ["1.5", "half", "-0.1"])
def test_calibrate_fit_exits_2_on_a_bad_split(tmp_path, capsys, split):
    data, _ = _small_file(tmp_path)
    assert main(["calibrate", "fit", "--data", str(data), "--out", str(tmp_path / "o"), "--split", split]) == 2
    assert "--split" in capsys.readouterr().err


def test_calibrate_evaluate_from_flight_fit_initial_states(tmp_path):
    """The optional diagnostic mode, end to end, on free-flight tosses simulated with the
    parameters (no impact: the cube starts 5 m above the table). The first-frame rollout
    reproduces such data exactly; the flight fit's model is the exact parabola, which
    Drake's discrete step (semi-implicit Euler, h ~ 1 ms) misses by O(g h t), so the
    flight-fit rollout must be off by more than zero and by less than g h t_end (1.2 mm,
    2.4% of a width here; measured 0.93%). A fit that ignored the frames, or gravity,
    would be off by centimetres."""
    truth = CubeTossParams(model="point", mu=0.3, point_contact_stiffness=1e5)
    starts = [([0, 0, 5.0], [10, 20, 0], [4, 1, 0], [1.0, 0.2, -0.5]), ([0, 0, 5.0], [0, 35, 15], [-2, 3, 1], [0.6, -0.8, 0.0])]
    tosses = _simulated([_synthetic_toss(i, *s, n=40) for i, s in enumerate(starts)], truth)
    data = save_tosses(tmp_path / "flight.npz", tosses, DT)
    params = tmp_path / "params.yaml"
    params.write_text(to_fragment(truth))
    h = TossSimulator(truth, DT).time_step
    for initial in ("first-frame", "flight-fit"):
        out = tmp_path / initial
        assert main(["calibrate", "evaluate", "--data", str(data), "--params", str(params), "--out", str(out),
                     "--workers", "1", "--initial-state", initial]) == 0
        metrics = json.loads((out / "metrics.json").read_text())
        assert metrics["initial_state"] == initial
        if initial == "first-frame":
            assert metrics["position_error_mean"] < 1e-9  # same code, same numbers
        else:
            assert 1e-6 < metrics["position_error_mean"] < GRAVITY * h * tosses[0].t[-1] / CUBE_WIDTH
