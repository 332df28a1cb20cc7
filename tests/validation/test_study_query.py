"""Query study (testbed.studies.query): outputs, polygon-soup convergence, MuJoCo's
normal, the paper MLP's decoding. Never asserts absolute times (2 shared cores)."""

import json

import numpy as np
import pytest

pytest.importorskip("fcl", reason="pip install -e '.[study]'")
pytest.importorskip("mujoco", reason="pip install -e '.[study]'")
pytest.importorskip("matplotlib", reason="pip install -e '.[study]'")

from testbed.bodies.containers import CONTAINER_TYPES  # noqa: E402
from testbed.geometry.rotations import rotation_from_rpy  # noqa: E402
from testbed.studies import query  # noqa: E402
from testbed.studies.query.methods.drake import DrakeBoxPair  # noqa: E402
from testbed.studies.query.methods.mujoco import MujocoBoxPair  # noqa: E402
from testbed.studies.query.methods.polygon_soup import PolygonSoupPair, box_triangles, crossing_segments  # noqa: E402

METHOD_KEYS = {"drake_point", "drake_hydro_cc", "drake_hydro_cr", "soup_segments_N8", "mujoco", "paper_mlp_single",
               "paper_mlp_batched", "improved_single", "improved_batched"}


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("query")
    metrics = query.run_query_study(out, quick=True, progress=False)
    return out, metrics


def test_quick_study_writes_its_three_files(quick_run):
    out, metrics = quick_run
    for name in ("query.json", "query.md", "query_pareto.png"):
        assert (out / name).is_file() and (out / name).stat().st_size > 0, name
    assert (out / "query_pareto.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    text = (out / "query.md").read_text()
    # the markdown is rendered from the measured data: each N's Table 4 row carries the
    # colliding triangle pairs this run counted (not the paper's constants)
    for n in query.SOUP_N_QUICK:
        row = next(line for line in text.splitlines() if line.startswith(f"| {n} |") and line.count("|") == 9)
        cells = [c.strip() for c in row.strip("|").split("|")]
        assert int(cells[3]) == metrics["polygon_soup"][str(n)]["max_colliding_pairs"], row
    assert json.loads((out / "query.json").read_text()) == json.loads(json.dumps(metrics))


def test_json_has_the_documented_keys(quick_run):
    out, _ = quick_run
    m = json.loads((out / "query.json").read_text())
    assert m["schema"] == query.SCHEMA
    for key in ("config", "environment", "reference", "pose_sets", "methods", "polygon_soup", "near_parallel_by_tilt", "markdown",
                "pareto", "paper", "wall_time_s", "files"):
        assert key in m, key
    assert set(m["pose_sets"]) == set(query.POSE_SETS)
    assert all(v["n"] > 0 for v in m["pose_sets"].values())
    assert METHOD_KEYS <= set(m["methods"])
    assert {f"soup_N{n}" for n in query.SOUP_N_QUICK} <= set(m["methods"])
    for name, v in m["methods"].items():
        assert {"label", "family", "available", "reason"} <= set(v), name
        if not v["available"]:
            assert v["reason"], name
            continue
        for stat in ("time_us", "point_error_m", "normal_error_deg"):
            assert {"mean", "median", "p99", "max", "n", "n_missing"} <= set(v["all"][stat]), (name, stat)
        assert v["all"]["time_us"]["mean"] > 0
        assert set(v["by_set"]) == set(query.POSE_SETS)
    # (the reference is checked against an independent method, the exact polygon-soup
    # rim, in test_polygon_soup_point_converges_to_hydroelastic_cop_face_on_face)
    for n in query.SOUP_N_QUICK:
        row = m["polygon_soup"][str(n)]
        assert row["triangles_per_box"] == 12 * n * n
        assert row["max_colliding_pairs"] > 0 and row["max_candidate_pairs"] >= row["max_colliding_pairs"]
    assert m["pareto"]["point_front"] and m["pareto"]["normal_front"]


def test_box_triangulation_counts_and_normals():
    V, T, normals = box_triangles((2.0, 1.0, 0.5), 8)
    assert len(T) == 12 * 8**2  # 2 N^2 per face
    tri = V[T]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    np.testing.assert_allclose(n, normals, atol=1e-12)  # counter-clockwise from outside
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1).sum()
    assert area == pytest.approx(2 * (2.0 * 1.0 + 2.0 * 0.5 + 1.0 * 0.5))


def test_crossing_segment_of_two_triangles():
    a = np.array([[[-1.0, -1, 0], [1, -1, 0], [0, 1, 0]]])  # in z = 0
    b = np.array([[[0.0, -2, -1], [0, 2, -1], [0, 0, 1]]])  # in x = 0, crossing a
    seg = crossing_segments(a, b)[0]
    assert np.allclose(seg[:, 0], 0) and np.allclose(seg[:, 2], 0)
    np.testing.assert_allclose(sorted(seg[:, 1]), [-1.0, 1.0], atol=1e-12)


def _stack_pose(pair: DrakeBoxPair, xy, R, depth):
    """B's centre height [m] at which Drake's signed distance is -depth (bisection)."""
    lo, hi = 0.0, 10.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        q = pair.set_pose([xy[0], xy[1], mid], R)
        if q.ComputeSignedDistancePairClosestPoints(pair.gid_a, pair.gid_b).distance < -depth:
            lo = mid
        else:
            hi = mid
    return np.array([xy[0], xy[1], hi])


def test_polygon_soup_point_converges_to_hydroelastic_cop_face_on_face():
    """A 1CC lying yawed on a 1AA, 5 mm overlap, faces parallel: the soup's point from
    the colliding triangles approaches Drake's centre of pressure as N grows; its error
    is of the order of the triangle size (tolerances below)."""
    a, b = CONTAINER_TYPES["1AA"], CONTAINER_TYPES["1CC"]
    drake = DrakeBoxPair("1AA", "1CC")
    errors = {8: [], 22: []}
    for yaw in (0.2, 0.3, 0.45, 0.6):
        R = rotation_from_rpy(np.array([[0.0, 0.0, yaw]]))[0]
        p = _stack_pose(drake, (2.0, 0.3), R, 0.005)
        ref = drake.query(p, R, "hydro_cc")
        for n in errors:
            soup = PolygonSoupPair(a.size, b.size, n).query(p, R)
            assert soup.n_pairs > 0
            errors[n].append(np.linalg.norm(soup.point - ref.point))
            assert np.degrees(np.arccos(min(1.0, soup.normal @ ref.normal))) < 1.0  # face normal found
        exact = PolygonSoupPair(a.size, b.size, 8).query(p, R, "segments")
        assert np.linalg.norm(exact.point - ref.point) < 5e-3  # exact rim: area centroid = CoP here
    coarse, fine = np.mean(errors[8]), np.mean(errors[22])
    assert fine < 0.6 * coarse, errors
    assert fine < 0.06, errors  # [m]; a triangle at N = 22 is 0.55 m x 0.11 m on A's top


@pytest.mark.parametrize("below", [False, True])
def test_mujoco_normal_points_from_A_to_B_when_stacked(below):
    size = CONTAINER_TYPES["1CC"].size
    pair = MujocoBoxPair(size, size)
    z = (size[2] - 0.004) * (-1.0 if below else 1.0)  # B 4 mm into A's top (or bottom) face
    R = rotation_from_rpy(np.array([[0.001, -0.002, 0.3]]))[0]
    ans = pair.query([0.4, 0.1, z], R)
    assert ans.n_contacts >= 1
    expected = np.array([0.0, 0.0, -1.0 if below else 1.0])
    assert np.degrees(np.arccos(min(1.0, ans.normal @ expected))) < 0.5
    assert abs(abs(ans.point[2]) - 0.5 * size[2]) < 0.01  # on A's face [m]


def test_paper_mlp_decoding_puts_the_point_on_A_surface():
    """A constant 'network' (zero weights) decodes to the same canonical direction; the
    point must lie on A's surface and the normal be unit, reflected into B's octant."""
    from learned_contact.model.encodings import spherical
    from learned_contact.model.mlp import NumpyMLP

    d, f = np.array([[0.9, 0.3, 0.2]]), np.array([[0.1, 0.2, 1.0]])
    bias = np.concatenate([spherical(d / np.linalg.norm(d)), spherical(f / np.linalg.norm(f))], 1)[0]
    mlp = NumpyMLP((np.zeros((6, 4)),), (bias,), "tanh", np.zeros(6), np.ones(6))
    size_A = np.array([6.058, 2.438, 2.591])
    p_AB = np.array([[3.0, -1.0, 2.0], [-2.0, 1.0, -2.5]])
    R_AB = np.repeat(np.eye(3)[None], 2, axis=0)
    point, normal = query.paper_predict(mlp, p_AB, R_AB, size_A)
    assert np.allclose(np.max(np.abs(point) / (0.5 * size_A), axis=1), 1.0)  # on the box surface
    assert np.all(np.sign(point) == np.sign(p_AB))
    np.testing.assert_allclose(np.linalg.norm(normal, axis=1), 1.0)


def test_pareto_front():
    front = query.pareto_front({"fast_bad": (1.0, 1.0), "slow_good": (10.0, 0.1), "dominated": (20.0, 0.5),
                                "middle": (5.0, 0.5)})
    assert front == ["fast_bad", "middle", "slow_good"]


def test_missing_optional_package_names_the_install_command(monkeypatch):
    import builtins

    from testbed.errors import OptionalDependencyError

    real_import = builtins.__import__

    def fake_import(name, *args, **kwargs):
        if name == "mujoco":
            raise ImportError("no mujoco")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", fake_import)
    with pytest.raises(OptionalDependencyError, match=r"pip install -e '\.\[study\]'"):
        query.run_query_study("/nonexistent/never-written", quick=True, progress=False)
    with pytest.raises(OptionalDependencyError, match="mujoco"):
        MujocoBoxPair((1.0, 1.0, 1.0), (1.0, 1.0, 1.0))
