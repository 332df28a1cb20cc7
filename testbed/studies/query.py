"""Query-level study: what each contact method costs per query and how accurate it is.

    from testbed.studies.query import run_query_study
    metrics = run_query_study("reports/query", quick=True)

On the same poses of a container pair (A, B), every method is asked for one contact
point and one normal, timed side by side in this process, and compared with the
reference: Drake's static hydroelastic answer (compliant-compliant, E = 1e8 Pa), its
centre of pressure (CoP) and pressure-weighted normal (learned_contact/labels.py).

Pose sets (B's pose in A's frame, A at the origin; container types 1CC, 1AA, 1AAA)
- "stacking", "general": learned_contact.sampling's distributions, labelled by
  learned_contact.labels.make_dataset (sampling seed 10 * seed + 7, disjoint from the
  training seeds 10 * seed + 1 and + 2);
- "near_parallel": the paper's worst case (its Figure 4): B of the same type stacked
  on A, yaw a multiple of pi, centred within +-0.1 m, tilted about a random horizontal
  axis by angles log-spaced from 1e-5 to 1e-1 rad, penetration 0.1 to 5 mm.

Methods (names are the keys of metrics["methods"])
- drake_point: QueryObject.ComputePointPairPenetration (one pair, FCL's dBoxBox);
- drake_hydro_cc / drake_hydro_cr: QueryObject.ComputeContactSurfaces, compliant B /
  rigid B, reduced to CoP and normal (drake_hydro_cc is the reference: zero error);
- soup_N<N>: the paper's RAPID baseline with python-fcl, N divisions per edge, point
  from the colliding triangles' centroids (polygon_soup.py); soup_segments_N8: the
  same triangle pairs at N = 8 with exact crossing segments;
- mujoco: MuJoCo's box-box collision, contacts reduced to one point and normal;
- paper_mlp_single / paper_mlp_batched: the paper-faithful 6-20-18-4 tanh MLP
  (learned_contact/shipped/paper_weights.npz), one pair per call / all pairs per call;
- improved_single / improved_batched: learned_contact.load_predictor().
A method whose package or weights are missing is listed with available = false and
the reason; the optional packages themselves raise OptionalDependencyError.

Timing: time.perf_counter_ns around each call; every pose is run once to warm up,
then `repeats` times; a pose's time is the fastest of its repeats (the cost without
interference from other processes on shared cores), and mean, p99 and max are taken
over poses (for batched calls: the batch time divided by its size). numpy's BLAS is
limited to one thread while measuring (threadpoolctl, when installed), so every
method runs on one core; on 2 shared cores a threaded BLAS made batched MLP calls
10x slower and erratic.
"query" time = pose in -> point and normal out, including Python glue; "kernel" time
= the library's collision call alone on an already-posed scene (Drake query,
fcl.collide, mj_collision). Absolute times depend on the machine: compare ratios.

Outputs in out_dir: query.json (metrics, schema SCHEMA below), query.md (tables, the
paper's Tables 3 and 4 next to today's figures), query_pareto.png (time per query,
log scale, against point and normal error).

query.json keys: schema; config (n_poses, seed, quick, repeats, soup_N, ...);
environment (versions, pins, blas_threads); reference; pose_sets {name: {n,
n_dropped}}; methods {name: {label, family, available, reason, [N,
triangles_per_box], all and by_set {set: {time_us, [kernel_time_us],
point_error_m, normal_error_deg, [count]}}, [throughput_us_per_pair]}}, each
statistic {n, n_missing, mean, median, p99, max}; polygon_soup {N: the paper's
Tables 3 and 4 on today's tools}; near_parallel_by_tilt; pareto {point_front,
normal_front}; paper (its Tables 3 and 4 and MLP time, quoted); wall_time_s; files;
markdown (the text of query.md). Timing-dependent (differ between runs): every
*time_us*, *_ms*, throughput_us_per_pair, wall_time_s, pareto, markdown.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import math
import platform
import sys
import time
from pathlib import Path

import numpy as np

from testbed.contact_geometry import angle_between
from testbed.errors import OptionalDependencyError

SCHEMA = "testbed.study.query/1"
POSE_SETS = ("stacking", "general", "near_parallel")
TYPES = ("1CC", "1AA", "1AAA")
SOUP_N_FULL = (8, 10, 12, 14, 16, 18, 20, 22)
SOUP_N_QUICK = (8, 14, 22)
TILT_RANGE = (1e-5, 1e-1)  # [rad] near-parallel set
NEAR_DEPTH = (1e-4, 5e-3)  # [m] near-parallel penetration
STUDY_SEED_OFFSET = 7  # sampling seed = 10 * seed + 7
NEAR_VERSION = 1  # bump when the near-parallel set changes meaning
PINS = {"python-fcl": "0.7.0.11", "mujoco": "4.0.0", "matplotlib": "3.11.2", "threadpoolctl": "3.8.0"}
INSTALL = "pip install -e '.[study]'"

# The paper's figures (Pentium IV, 1.5 GHz, RAPID, gprof), quoted from its text.
# Table 3: N, "Triangles/face" (the values are per box: 12 N^2), average time [ms].
PAPER_TABLE_3 = {8: (768, 1.10), 10: (1200, 1.47), 12: (1728, 1.85), 14: (2352, 1.94),
                 16: (3072, 2.13), 18: (3888, 2.31), 20: (4800, 2.72), 22: (5808, 2.90)}
# Table 4: N, "Max. test", time of the pattern with the most tests [ms].
PAPER_TABLE_4 = {8: (11233, 11.52), 10: (14323, 15.47), 12: (17911, 19.2), 14: (21789, 23.13),
                 16: (24667, 24.63), 18: (26517, 28.0), 20: (30475, 32.44), 22: (35411, 36.77)}
PAPER_MLP_MS = 0.5  # Section 5: "it takes around 0.5 milliseconds"


# ----------------------------------------------------------------------------- poses
@dataclasses.dataclass(frozen=True)
class PoseSet:
    """Labelled poses of one set. Arrays in A's frame.

    p_AB (n, 3) [m]; R_AB (n, 3, 3); size_A, size_B (n, 3) full extents [m];
    type_a, type_b (n,) ISO codes; cop (n, 3) [m] and normal (n, 3) unit A->B: the
    reference; depth (n,) [m]; tilt (n,) [rad] (near_parallel only, else NaN).
    """

    name: str
    p_AB: np.ndarray
    R_AB: np.ndarray
    size_A: np.ndarray
    size_B: np.ndarray
    type_a: np.ndarray
    type_b: np.ndarray
    cop: np.ndarray
    normal: np.ndarray
    depth: np.ndarray
    tilt: np.ndarray
    n_dropped: int = 0

    def __len__(self) -> int:
        return len(self.depth)


def _type_codes(sizes) -> np.ndarray:
    from testbed.containers import CONTAINER_TYPES

    table = {tuple(np.round(t.size, 6)): code for code, t in CONTAINER_TYPES.items()}
    return np.array([table[tuple(np.round(s, 6))] for s in sizes])


def _from_dataset(name: str, ds, tilt=None) -> PoseSet:
    n = len(ds)
    return PoseSet(name, ds.p_AB, ds.R_AB, ds.size_A, ds.size_B, _type_codes(ds.size_A), _type_codes(ds.size_B),
                   ds.cop, ds.normal, ds.depth, np.full(n, np.nan) if tilt is None else tilt, ds.n_dropped)


def near_parallel_proposals(n: int, seed: int):
    """n proposals (learned_contact.sampling.Proposals) of the near-parallel worst case
    and their tilts (n,) [rad] (see the module docstring)."""
    from learned_contact.geometry import rotation_from_rpy
    from learned_contact.sampling import Proposals

    rng = np.random.default_rng([seed, 99])
    kind = rng.integers(len(TYPES), size=n)
    tilt = np.geomspace(*TILT_RANGE, n) if n > 1 else np.array([TILT_RANGE[0]])
    axis = rng.uniform(-np.pi, np.pi, size=n)  # tilt axis azimuth in A's xy plane
    yaw = np.pi * rng.integers(2, size=n)
    R_tilt = rotation_from_rpy(np.stack([tilt * np.cos(axis), tilt * np.sin(axis), np.zeros(n)], 1))
    R_yaw = rotation_from_rpy(np.stack([np.zeros(n), np.zeros(n), yaw], 1))
    base = np.concatenate([rng.uniform(-0.1, 0.1, size=(n, 2)), np.zeros((n, 1))], 1)
    props = Proposals(TYPES, kind, kind.copy(), R_tilt @ R_yaw, base, np.tile([0.0, 0.0, 1.0], (n, 1)),
                      rng.uniform(*NEAR_DEPTH, size=n))
    return props, tilt


def make_pose_sets(n_poses: int, seed: int, *, progress: bool = True, use_cache: bool = True) -> dict:
    """{name: PoseSet} for POSE_SETS, n_poses proposals each (poses without a contact
    surface are dropped and counted). Labels are cached (learned_contact.cache)."""
    from learned_contact import cache
    from learned_contact.labels import LABEL_FIELDS, LABEL_VERSION, Dataset, label_proposals, make_dataset

    s = 10 * seed + STUDY_SEED_OFFSET
    out = {}
    for dist in ("stacking", "general"):
        ds = make_dataset(dist, n_poses, s, types=TYPES, workers=1, progress=progress, use_cache=use_cache)
        out[dist] = _from_dataset(dist, ds)
    props, tilt = near_parallel_proposals(n_poses, s)
    key = cache.key("study-near-parallel", n_poses, s, TYPES, LABEL_VERSION, NEAR_VERSION)
    rows = cache.load(key) if use_cache else None
    if rows is None:
        rows = label_proposals(props, workers=1, progress=progress)
        if use_cache:
            cache.save(key, rows)
    ok = np.isfinite(rows[:, 4]) & np.isfinite(rows[:, 7])
    size_A, size_B = props.sizes()
    get = lambda f: rows[:, LABEL_FIELDS[f]]  # noqa: E731
    ds = Dataset("near_parallel", get("p_AB"), props.R_AB, size_A, size_B, get("cop"), get("normal"),
                 get("depth")[:, 0], get("area")[:, 0], np.zeros(len(rows), int), get("pp_point"),
                 get("pp_normal"), get("pp_depth")[:, 0], 0)
    ds = dataclasses.replace(ds.subset(ok), n_dropped=int((~ok).sum()))
    out["near_parallel"] = _from_dataset("near_parallel", ds, tilt[ok])
    return out


# --------------------------------------------------------------------------- methods
@dataclasses.dataclass
class Method:
    """One way of answering a contact query.

    single(i) -> (point (3,) [m], normal (3,) unit A->B, count) for pose i of the
    set, count being an int reported per pose (Drake surface faces or point pairs,
    colliding triangle pairs, MuJoCo contacts) or None; or batched() -> (points (n, 3),
    normals (n, 3)) for the whole set; prepare_kernel(i): poses the scene for pose i
    and returns the zero-argument library call to time alone (None: no kernel time).
    available False (with reason) when a package or weights file is missing.
    """

    name: str
    label: str
    family: str
    available: bool = True
    reason: str = ""
    single: object = None
    batched: object = None
    prepare_kernel: object = None  # prepare_kernel(i) -> zero-argument callable to time
    extra: dict = dataclasses.field(default_factory=dict)


def _paper_mlp(path=None):
    """The paper-faithful MLP (learned_contact.mlp.NumpyMLP) stored at `path` (default
    learned_contact/shipped/paper_weights.npz), or raises FileNotFoundError."""
    from learned_contact.mlp import NumpyMLP
    from learned_contact.predictor import SHIPPED_DIR

    path = Path(path) if path is not None else SHIPPED_DIR / "paper_weights.npz"
    if not path.is_file():
        raise FileNotFoundError(f"{path} not found (made by learned_contact.training.train_default)")
    with np.load(path, allow_pickle=False) as data:
        return NumpyMLP.from_arrays({k: data[k] for k in data.files}, "mlp/")


def paper_predict(mlp, p_AB, R_AB, size_A):
    """Decodes the paper MLP's 4 outputs into a point and a normal.

    p_AB (n, 3) [m], R_AB (n, 3, 3), size_A (n, 3) or (3,) [m]. The first two outputs
    are the spherical angles of the contact point's direction from A's centre in the
    canonical (positive-octant) frame; the point is where that ray leaves box A (the
    paper: "the length ... can be obtained from its direction, since it must lie on the
    surface of the cube"). The last two are the force direction. Returns (point (n, 3)
    [m], normal (n, 3) unit A->B) in A's frame.
    """
    from learned_contact.encodings import from_spherical, octant_signs
    from learned_contact.paper_mlp import paper_inputs

    y = mlp(paper_inputs(p_AB, R_AB))  # (n, 4) [rad]
    S = octant_signs(p_AB)
    d = from_spherical(y[:, :2])
    reach = np.max(np.abs(d) / (0.5 * np.asarray(size_A, dtype=float)), axis=1)  # (n,)
    point = S * d / reach[:, None]
    normal = S * from_spherical(y[:, 2:4])
    return point, normal / np.linalg.norm(normal, axis=1, keepdims=True)


class _Scenes:
    """Lazily built per-type-pair scenes (Drake plants, FCL meshes, MuJoCo models)."""

    def __init__(self):
        self._cache = {}

    def get(self, kind, *key):
        k = (kind, *key)
        if k not in self._cache:
            if kind == "drake":
                from testbed.studies.drake_pair import DrakeBoxPair

                self._cache[k] = DrakeBoxPair(key[0], key[1], rigid_b=key[2])
            elif kind == "soup":
                from testbed.studies.polygon_soup import PolygonSoupPair

                self._cache[k] = PolygonSoupPair(key[0], key[1], key[2])
            elif kind == "mujoco":
                from testbed.studies.mujoco_boxes import MujocoBoxPair

                self._cache[k] = MujocoBoxPair(key[0], key[1])
        return self._cache[k]


def build_methods(poses: PoseSet, scenes: _Scenes, soup_ns, *, predictor=None, paper_weights=None) -> list[Method]:
    """The study's methods bound to the poses of one set (see the module docstring).

    predictor: weights path for learned_contact.load_predictor (None: shipped default);
    paper_weights: path of the paper MLP's .npz (None: shipped default).
    """
    P, R, SA, SB, TA, TB = poses.p_AB, poses.R_AB, poses.size_A, poses.size_B, poses.type_a, poses.type_b
    methods = []

    def drake(mode, rigid):
        def scene(i):
            return scenes.get("drake", str(TA[i]), str(TB[i]), rigid)

        def single(i):
            a = scene(i).query(P[i], R[i], mode)
            return a.point, a.normal, a.n_faces

        def prep(i):
            sc = scene(i)
            q = sc.set_pose(P[i], R[i])
            return lambda: sc.kernel(q, mode)

        return single, prep

    for name, label, mode, rigid in (
        ("drake_point", "Drake point contact", "point", False),
        ("drake_hydro_cc", "Drake hydroelastic compliant-compliant", "hydro_cc", False),
        ("drake_hydro_cr", "Drake hydroelastic compliant-rigid", "hydro_cr", True),
    ):
        single, prep = drake(mode, rigid)
        methods.append(Method(name, label, "drake", single=single, prepare_kernel=prep))

    try:
        import fcl  # noqa: F401

        fcl_ok, fcl_reason = True, ""
    except ImportError:
        fcl_ok, fcl_reason = False, f"python-fcl not installed ({INSTALL})"

    def soup(n, estimator):
        def single(i):
            a = scenes.get("soup", tuple(SA[i]), tuple(SB[i]), n).query(P[i], R[i], estimator)
            return a.point, a.normal, a.n_pairs

        def prep(i):
            sc = scenes.get("soup", tuple(SA[i]), tuple(SB[i]), n)
            sc.set_pose(P[i], R[i])
            return sc.collide

        return single, prep

    for n in soup_ns:
        single, prep = soup(n, "centroids")
        methods.append(Method(f"soup_N{n}", f"polygon soup N={n} (python-fcl)", "polygon_soup", fcl_ok, fcl_reason,
                              single=single, prepare_kernel=prep, extra={"N": n, "triangles_per_box": 12 * n * n}))
    single, prep = soup(8, "segments")
    methods.append(Method("soup_segments_N8", "polygon soup N=8, exact crossing segments", "polygon_soup",
                          fcl_ok, fcl_reason, single=single, prepare_kernel=prep,
                          extra={"N": 8, "triangles_per_box": 768}))

    try:
        import mujoco  # noqa: F401

        def mj_single(i):
            a = scenes.get("mujoco", tuple(SA[i]), tuple(SB[i])).query(P[i], R[i])
            return a.point, a.normal, a.n_contacts

        def mj_prep(i):
            sc = scenes.get("mujoco", tuple(SA[i]), tuple(SB[i]))
            sc.set_pose(P[i], R[i])
            return sc.collide

        methods.append(Method("mujoco", "MuJoCo box-box (mj_collision)", "mujoco", single=mj_single,
                              prepare_kernel=mj_prep))
    except ImportError:
        methods.append(Method("mujoco", "MuJoCo box-box (mj_collision)", "mujoco", False,
                              f"mujoco not installed ({INSTALL})"))

    try:
        mlp = _paper_mlp(paper_weights)
        methods.append(Method("paper_mlp_single", "paper MLP 6-20-18-4, one pair per call", "learned",
                              single=lambda i: (*[v[0] for v in paper_predict(mlp, P[i:i + 1], R[i:i + 1], SA[i])], None)))
        methods.append(Method("paper_mlp_batched", "paper MLP 6-20-18-4, batched", "learned",
                              batched=lambda: paper_predict(mlp, P, R, SA)))
    except Exception as exc:  # noqa: BLE001 - missing or unreadable weights: report, go on
        for name, how in (("paper_mlp_single", "one pair per call"), ("paper_mlp_batched", "batched")):
            methods.append(Method(name, f"paper MLP 6-20-18-4, {how}", "learned", False, f"{type(exc).__name__}: {exc}"))

    try:
        from learned_contact import load_predictor

        pred = load_predictor(predictor)
        methods.append(Method("improved_single", "improved predictor, one pair per call", "learned",
                              single=lambda i: (*pred.predict(P[i], R[i], size_A=SA[i], size_B=SB[i]), None)))
        methods.append(Method("improved_batched", "improved predictor, batched", "learned",
                              batched=lambda: pred.predict(P, R, size_A=SA, size_B=SB)))
    except Exception as exc:  # noqa: BLE001 - missing or unreadable weights: report, go on
        for name, how in (("improved_single", "one pair per call"), ("improved_batched", "batched")):
            methods.append(Method(name, f"improved predictor, {how}", "learned", False, f"{type(exc).__name__}: {exc}"))
    return methods


# -------------------------------------------------------------------------- measure
def _min_ns(fn, repeats: int) -> float:
    """Fastest wall time [ns] of `repeats` calls of fn (after the caller's warm-up): the
    cost of the call without interference from other processes on shared cores."""
    best = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter_ns()
        fn()
        best = min(best, time.perf_counter_ns() - t0)
    return float(best)


def measure_set(poses: PoseSet, methods: list[Method], repeats: int, *, progress: bool, with_candidates: bool):
    """Runs every available method on every pose of one set.

    Returns {method name: {"point" (n, 3), "normal" (n, 3), "count" (n,),
    "query_ns" (n,), "kernel_ns" (n,) or None, "candidates" (n,) (soup only)}}.
    """
    from tqdm import tqdm

    n = len(poses)
    out = {}
    for m in methods:
        if not m.available:
            continue
        point, normal = np.full((n, 3), np.nan), np.full((n, 3), np.nan)
        count, q_ns = np.full(n, -1, dtype=np.int64), np.full(n, np.nan)
        k_ns = np.full(n, np.nan) if m.prepare_kernel is not None else None
        if m.batched is not None:
            m.batched()  # warm-up
            t = np.empty(repeats)
            for r in range(repeats):
                t0 = time.perf_counter_ns()
                pts, nrm = m.batched()
                t[r] = time.perf_counter_ns() - t0
            point[:], normal[:] = pts, nrm
            q_ns[:] = np.min(t) / n
            out[m.name] = {"point": point, "normal": normal, "count": count, "query_ns": q_ns, "kernel_ns": None,
                           "batch_ns": t / n}
            continue
        for i in tqdm(range(n), desc=f"{poses.name}: {m.name}", disable=not progress, leave=False):
            p, nr, c = m.single(i)  # warm-up, and the answer
            point[i], normal[i] = p, nr
            count[i] = -1 if c is None else c
            q_ns[i] = _min_ns(lambda: m.single(i), repeats)
            if k_ns is not None:
                fn = m.prepare_kernel(i)
                fn()
                k_ns[i] = _min_ns(fn, repeats)
        res = {"point": point, "normal": normal, "count": count, "query_ns": q_ns, "kernel_ns": k_ns}
        if with_candidates and m.family == "polygon_soup" and m.name.startswith("soup_N"):
            from testbed.studies.polygon_soup import PolygonSoupPair

            cand = np.zeros(n, dtype=np.int64)
            for i in range(n):
                sc = PolygonSoupPair(poses.size_A[i], poses.size_B[i], m.extra["N"])
                cand[i] = sc.candidate_pairs(poses.p_AB[i], poses.R_AB[i])
            res["candidates"] = cand
        out[m.name] = res
    return out


def _stats(values, scale: float = 1.0) -> dict:
    """n, n_missing (NaN), mean, median, p99, max of values * scale (finite values only)."""
    v = np.asarray(values, dtype=float) * scale
    ok = np.isfinite(v)
    if not ok.any():
        return {"n": 0, "n_missing": int(len(v)), "mean": None, "median": None, "p99": None, "max": None}
    f = v[ok]
    return {"n": int(ok.sum()), "n_missing": int((~ok).sum()), "mean": float(f.mean()),
            "median": float(np.median(f)), "p99": float(np.percentile(f, 99)), "max": float(f.max())}


def _errors(res: dict, poses: PoseSet):
    e_point = np.linalg.norm(res["point"] - poses.cop, axis=1)  # (n,) [m]
    e_normal = np.degrees(angle_between(res["normal"], poses.normal))  # (n,) [deg]
    return e_point, e_normal


def _summary(res_list, poses_list) -> dict:
    """Figures of one method over one or more sets (concatenated)."""
    q = np.concatenate([r["query_ns"] for r in res_list])
    e = [_errors(r, p) for r, p in zip(res_list, poses_list)]
    out = {"time_us": _stats(q, 1e-3), "point_error_m": _stats(np.concatenate([a for a, _ in e])),
           "normal_error_deg": _stats(np.concatenate([b for _, b in e]))}
    if res_list[0]["kernel_ns"] is not None:
        out["kernel_time_us"] = _stats(np.concatenate([r["kernel_ns"] for r in res_list]), 1e-3)
    if "batch_ns" in res_list[0]:
        # per-pair time of each repeat of each set's batch call
        b = np.concatenate([r["batch_ns"] for r in res_list]) * 1e-3
        out["time_us"].update({"p99": float(np.percentile(b, 99)), "max": float(b.max())})
    counts = np.concatenate([r["count"] for r in res_list])
    if np.any(counts >= 0):
        out["count"] = {"mean": float(counts[counts >= 0].mean()), "max": int(counts.max())}
    return out


def pareto_front(points: dict) -> list[str]:
    """Names not dominated in (time, error): {name: (time, error)} -> sorted by time."""
    items = sorted((t, e, k) for k, (t, e) in points.items() if t is not None and e is not None)
    front, best = [], math.inf
    for t, e, k in items:
        if e < best:
            front.append(k)
            best = e
    return front


def _environment() -> dict:
    from importlib import metadata

    versions = {}
    for pkg in ("drake", "numpy", "python-fcl", "mujoco", "matplotlib", "threadpoolctl"):
        try:
            versions[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            versions[pkg] = None
    import os

    return {"python": sys.version.split()[0], "platform": platform.platform(), "machine": platform.machine(),
            "cpu_count": os.cpu_count(), "packages": versions, "pins": PINS}


@contextlib.contextmanager
def _one_blas_thread():
    """Limits numpy's BLAS to one thread (threadpoolctl); yields a note for the report."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:
        yield "not limited (threadpoolctl not installed)"
        return
    with threadpool_limits(limits=1):
        yield 1


# --------------------------------------------------------------------------- study
def run_query_study(out_dir, *, n_poses: int | None = None, seed: int = 0, quick: bool = False,
                    progress: bool = True, repeats: int | None = None, soup_ns=None, predictor=None,
                    paper_weights=None) -> dict:
    """Runs the query study and writes query.json, query.md, query_pareto.png to out_dir.

    n_poses: proposals per pose set (default 200, quick 12); seed: sampling seed;
    quick: fewer poses, repeats (3) and soup resolutions (N = 8, 14, 22), well under a
    minute on 2 cores; repeats: timed calls per pose (default 7); soup_ns: N values to
    run; predictor, paper_weights: weights files of the improved predictor and the
    paper MLP (None: the shipped ones; missing files make those methods unavailable).
    Returns the metrics dict (JSON-serialisable; keys documented in query.md and the
    module docstring). Raises OptionalDependencyError when python-fcl, mujoco or
    matplotlib is missing (install with pip install -e '.[study]').
    """
    for pkg, mod in (("python-fcl", "fcl"), ("mujoco", "mujoco"), ("matplotlib", "matplotlib")):
        try:
            __import__(mod)
        except ImportError:
            raise OptionalDependencyError(pkg, "the query study", "study") from None
    t_start = time.perf_counter()
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    n_poses = n_poses if n_poses is not None else (24 if quick else 200)
    repeats = repeats if repeats is not None else (3 if quick else 7)
    soup_ns = tuple(soup_ns) if soup_ns is not None else (SOUP_N_QUICK if quick else SOUP_N_FULL)
    sets = make_pose_sets(n_poses, seed, progress=progress)
    t_labels = time.perf_counter() - t_start
    scenes = _Scenes()
    results, method_info = {}, {}
    with _one_blas_thread() as blas_threads:
        for name, poses in sets.items():
            methods = build_methods(poses, scenes, soup_ns, predictor=predictor, paper_weights=paper_weights)
            results[name] = measure_set(poses, methods, repeats, progress=progress, with_candidates=True)
            for m in methods:
                method_info.setdefault(m.name, m)
        throughput_args = (sets, scenes, soup_ns, repeats)
    metrics = {
        "schema": SCHEMA,
        "config": {"n_poses": n_poses, "seed": seed, "quick": quick, "repeats": repeats, "soup_N": list(soup_ns),
                   "types": list(TYPES), "tilt_range_rad": list(TILT_RANGE), "near_parallel_depth_m": list(NEAR_DEPTH),
                   "sampling_seed": 10 * seed + STUDY_SEED_OFFSET},
        "environment": _environment(),
        "reference": "Drake hydroelastic compliant-compliant (E = 1e8 Pa): centre of pressure and pressure-weighted "
                     "normal (learned_contact.labels)",
        "pose_sets": {k: {"n": len(v), "n_dropped": v.n_dropped} for k, v in sets.items()},
        "methods": {},
    }
    names = list(method_info)
    for name in names:
        m = method_info[name]
        entry = {"label": m.label, "family": m.family, "available": m.available, "reason": m.reason, **m.extra}
        if m.available:
            per = [(results[s][name], sets[s]) for s in sets if name in results[s] and len(sets[s])]
            entry["all"] = _summary([r for r, _ in per], [p for _, p in per])
            entry["by_set"] = {s: _summary([results[s][name]], [sets[s]]) for s in sets
                               if name in results[s] and len(sets[s])}
        metrics["methods"][name] = entry
    with _one_blas_thread():
        _throughput(metrics, *throughput_args, predictor=predictor, paper_weights=paper_weights)
    metrics["environment"]["blas_threads"] = blas_threads
    metrics["polygon_soup"] = _soup_tables(results, sets, soup_ns)
    metrics["near_parallel_by_tilt"] = _by_tilt(results, sets)
    avail = {k: v for k, v in metrics["methods"].items() if v["available"]}
    metrics["pareto"] = {
        "x": "all.time_us.mean", "y": ["all.point_error_m.mean", "all.normal_error_deg.mean"],
        "point_front": pareto_front({k: (v["all"]["time_us"]["mean"], v["all"]["point_error_m"]["mean"])
                                     for k, v in avail.items() if k != "drake_hydro_cc"}),
        "normal_front": pareto_front({k: (v["all"]["time_us"]["mean"], v["all"]["normal_error_deg"]["mean"])
                                      for k, v in avail.items() if k != "drake_hydro_cc"}),
    }
    metrics["paper"] = {"table3": {str(k): {"triangles": v[0], "avg_ms": v[1]} for k, v in PAPER_TABLE_3.items()},
                        "table4": {str(k): {"max_tests": v[0], "worst_ms": v[1]} for k, v in PAPER_TABLE_4.items()},
                        "mlp_ms": PAPER_MLP_MS,
                        "hardware": "Pentium IV 1.5 GHz, RAPID, timed with gprof"}
    metrics["wall_time_s"] = {"labels": t_labels, "total": time.perf_counter() - t_start}
    metrics["files"] = {"json": "query.json", "markdown": "query.md", "chart": "query_pareto.png"}
    write_chart(metrics, out_dir / "query_pareto.png")
    metrics["markdown"] = render_markdown(metrics)  # also read by testbed.report
    (out_dir / "query.md").write_text(metrics["markdown"])
    (out_dir / "query.json").write_text(json.dumps(metrics, indent=2, allow_nan=False) + "\n")
    return metrics


THROUGHPUT_BATCH = 4096  # pairs per call for the batched methods' throughput figure


def _throughput(metrics, sets, scenes, soup_ns, repeats, **weights) -> None:
    """Adds "throughput_us_per_pair" (batch of THROUGHPUT_BATCH pairs: all poses,
    repeated) to every available batched method in metrics["methods"]."""
    pooled = [v for v in sets.values() if len(v)]
    if not pooled:
        return
    idx = np.resize(np.arange(sum(len(v) for v in pooled)), THROUGHPUT_BATCH)
    cat = lambda f: np.concatenate([getattr(v, f) for v in pooled])[idx]  # noqa: E731
    big = PoseSet("pooled", cat("p_AB"), cat("R_AB"), cat("size_A"), cat("size_B"), cat("type_a"), cat("type_b"),
                  cat("cop"), cat("normal"), cat("depth"), cat("tilt"))
    for m in build_methods(big, scenes, (), **weights):
        if m.available and m.batched is not None and m.name in metrics["methods"]:
            m.batched()
            metrics["methods"][m.name]["throughput_us_per_pair"] = _min_ns(m.batched, repeats) * 1e-3 / THROUGHPUT_BATCH
            metrics["methods"][m.name]["throughput_batch"] = THROUGHPUT_BATCH


def _soup_tables(results, sets, soup_ns) -> dict:
    """Per N: the paper's Table 3 (average time) and Table 4 (the pose with the most
    triangle tests, its time) on today's tools, over all pose sets."""
    out = {}
    for n in soup_ns:
        name = f"soup_N{n}"
        per = [(s, results[s][name]) for s in sets if name in results[s] and len(sets[s])]
        if not per:
            continue
        q = np.concatenate([r["query_ns"] for _, r in per]) * 1e-6  # [ms]
        k = np.concatenate([r["kernel_ns"] for _, r in per]) * 1e-6
        pairs = np.concatenate([r["count"] for _, r in per])
        cand = np.concatenate([r.get("candidates", np.zeros(len(r["count"]), int)) for _, r in per])
        where = [(s, i) for s, r in per for i in range(len(r["count"]))]
        i_pairs, i_cand = int(np.argmax(pairs)), int(np.argmax(cand))
        typical = np.concatenate([r["kernel_ns"] for s, r in per if s != "near_parallel"]) * 1e-6
        out[str(n)] = {
            "triangles_per_box": 12 * n * n, "triangles_per_face": 2 * n * n,
            "avg_kernel_ms": float(np.nanmean(k)), "avg_kernel_ms_typical": float(np.nanmean(typical)) if len(typical) else None,
            "avg_query_ms": float(np.nanmean(q)),
            "max_colliding_pairs": int(pairs[i_pairs]), "max_pairs_pose": {"set": where[i_pairs][0], "index": where[i_pairs][1]},
            "kernel_ms_at_max_pairs": float(k[i_pairs]), "query_ms_at_max_pairs": float(q[i_pairs]),
            "max_candidate_pairs": int(cand[i_cand]), "kernel_ms_at_max_candidates": float(k[i_cand]),
            "worst_kernel_ms": float(np.nanmax(k)), "worst_query_ms": float(np.nanmax(q)),
            "p99_kernel_ms": float(np.nanpercentile(k, 99)),
        }
    return out


def _by_tilt(results, sets) -> dict:
    """Near-parallel set in tilt decades: per method mean point error [m] and mean
    query time [us] (the worst case of the paper grows as the tilt shrinks)."""
    poses = sets.get("near_parallel")
    if poses is None or len(poses) == 0:
        return {}
    edges = np.arange(math.floor(math.log10(TILT_RANGE[0])), math.ceil(math.log10(TILT_RANGE[1])) + 1)
    decade = np.clip(np.floor(np.log10(poses.tilt)).astype(int), edges[0], edges[-2])
    out = {"decades": [f"1e{d}..1e{d + 1}" for d in edges[:-1]], "methods": {}}
    for name, res in results["near_parallel"].items():
        e_point, _ = _errors(res, poses)
        rows = []
        for d in edges[:-1]:
            m = decade == d
            rows.append({"n": int(m.sum()),
                         "point_error_m": float(np.nanmean(e_point[m])) if m.any() and np.isfinite(e_point[m]).any() else None,
                         "time_us": float(np.nanmean(res["query_ns"][m]) * 1e-3) if m.any() else None,
                         "count_max": int(res["count"][m].max()) if m.any() else None})
        out["methods"][name] = rows
    return out


# -------------------------------------------------------------------------- output
def write_chart(metrics: dict, path) -> Path:
    """Pareto chart: mean query time [us] (log) against mean point error [m] and mean
    normal error [deg] (log), one marker per method, the polygon-soup N sweep joined."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    methods = {k: v for k, v in metrics["methods"].items() if v["available"] and "all" in v}
    fig, axes = plt.subplots(1, 2, figsize=(13, 5.5))
    colours = {"drake": "tab:blue", "polygon_soup": "tab:orange", "mujoco": "tab:green", "learned": "tab:red"}
    floor = {"point_error_m": 1e-5, "normal_error_deg": 1e-4}
    for ax, key, ylabel, front_key in ((axes[0], "point_error_m", "mean contact-point error [m]", "point_front"),
                                       (axes[1], "normal_error_deg", "mean normal error [deg]", "normal_front")):
        soup = sorted((v["N"], v["all"]["time_us"]["mean"], v["all"][key]["mean"]) for k, v in methods.items()
                      if k.startswith("soup_N") and v["all"][key]["mean"] is not None)
        if soup:
            ax.plot([s[1] for s in soup], [max(s[2], floor[key]) for s in soup], "-", color=colours["polygon_soup"],
                    alpha=0.5, zorder=1)
        for name, v in methods.items():
            t, e = v["all"]["time_us"]["mean"], v["all"][key]["mean"]
            if t is None or e is None:
                continue
            on_front = name in metrics["pareto"][front_key]
            is_ref = name == "drake_hydro_cc"
            ax.scatter([t], [max(e, floor[key])], color=colours.get(v["family"], "k"),
                       s=120 if is_ref else (60 if on_front else 30),
                       edgecolors="k" if on_front else "none", zorder=2,
                       marker="*" if is_ref else ("s" if "batched" in name else "o"))
            if not name.startswith("soup_N") or name in (f"soup_N{metrics['config']['soup_N'][0]}",
                                                          f"soup_N{metrics['config']['soup_N'][-1]}"):
                label = f"{name} (reference, error 0)" if is_ref else name
                ax.annotate(label, (t, max(e, floor[key])), fontsize=7, xytext=(4, 3), textcoords="offset points")
        ax.axvline(PAPER_MLP_MS * 1e3, color="tab:red", ls="--", lw=0.8, alpha=0.6)
        ax.text(PAPER_MLP_MS * 1e3, 0.03, " paper's MLP on a 1.5 GHz Pentium IV (0.5 ms)", rotation=90, fontsize=7,
                color="tab:red", transform=ax.get_xaxis_transform(), ha="right", va="bottom")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("mean time per query [us] (log)")
        ax.set_ylabel(ylabel + " (log; reference plotted at the floor)")
        ax.grid(True, which="both", alpha=0.3)
    n = sum(v["n"] for v in metrics["pose_sets"].values())
    fig.suptitle(f"Contact query cost vs accuracy against Drake hydroelastic CoP ({n} poses: "
                 f"{', '.join(metrics['pose_sets'])}); outlined = Pareto front, squares = batched")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)


def _f(x, fmt="{:.3g}") -> str:
    return "-" if x is None else fmt.format(x)


def render_markdown(metrics: dict) -> str:
    """query.md: setup, per-method table, per-set errors, the paper's Tables 3 and 4."""
    c, env = metrics["config"], metrics["environment"]
    lines = [
        "# Query study: what accuracy costs in time", "",
        f"Reference: {metrics['reference']}.",
        "Pose sets: " + ", ".join(f"{k} {v['n']} (dropped {v['n_dropped']})" for k, v in metrics["pose_sets"].items())
        + f"; seed {c['seed']} (sampling seed {c['sampling_seed']}); {c['repeats']} timed repeats per pose after a "
        f"warm-up, the fastest kept; BLAS threads while timing: {env.get('blas_threads')}; quick = {c['quick']}.",
        f"Machine: {env['platform']}, {env['cpu_count']} CPUs; Python {env['python']}; packages "
        + ", ".join(f"{k} {v}" for k, v in env["packages"].items()) + ".",
        "Times are per query in microseconds, measured side by side in one process (compare ratios, not absolute "
        "values). *query* = pose in, point and normal out (Python included); *kernel* = the library's collision call "
        "alone. Batched methods: one call per pose set, its time divided by the set's size (p99/max over repeats); "
        "their throughput at larger batches is listed under the tables. Errors: contact point [m] and normal [deg] "
        "against the reference.", "",
        "## Methods (all pose sets)", "",
        "| method | query mean | p99 | max | kernel mean | point err mean [m] | median | p99 | max | "
        "normal err mean [deg] | p99 | max | missing |",
        "|---|" + "---|" * 12,
    ]
    for name, v in metrics["methods"].items():
        if not v["available"]:
            lines.append(f"| {name} | not available: {v['reason']} |" + " |" * 11)
            continue
        a = v["all"]
        t, k, p, nr = a["time_us"], a.get("kernel_time_us"), a["point_error_m"], a["normal_error_deg"]
        lines.append(f"| {name} | {_f(t['mean'])} | {_f(t['p99'])} | {_f(t['max'])} | {_f(k['mean']) if k else '-'} | "
                     f"{_f(p['mean'])} | {_f(p['median'])} | {_f(p['p99'])} | {_f(p['max'])} | {_f(nr['mean'])} | "
                     f"{_f(nr['p99'])} | {_f(nr['max'])} | {p['n_missing']} |")
    lines += ["", f"Pareto front (mean time vs mean point error): {', '.join(metrics['pareto']['point_front'])}.",
              f"Pareto front (mean time vs mean normal error): {', '.join(metrics['pareto']['normal_front'])}.",
              "", "![Pareto chart](query_pareto.png)", "", "## Errors by pose set (mean point error [m] / mean normal "
              "error [deg] / mean query time [us])", "",
              "| method | " + " | ".join(metrics["pose_sets"]) + " |", "|---|" + "---|" * len(metrics["pose_sets"])]
    for name, v in metrics["methods"].items():
        if not v["available"]:
            continue
        cells = []
        for s in metrics["pose_sets"]:
            b = v["by_set"].get(s)
            cells.append("-" if b is None else f"{_f(b['point_error_m']['mean'])} / {_f(b['normal_error_deg']['mean'])}"
                         f" / {_f(b['time_us']['mean'])}")
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    tilt = metrics.get("near_parallel_by_tilt") or {}
    if tilt:
        lines += ["", "## Near-parallel worst case by tilt (mean point error [m]; soup: max colliding pairs)", "",
                  "| method | " + " | ".join(tilt["decades"]) + " |", "|---|" + "---|" * len(tilt["decades"])]
        for name, rows in tilt["methods"].items():
            cells = []
            for r in rows:
                s = _f(r["point_error_m"])
                if name.startswith("soup") and r["count_max"] is not None:
                    s += f" ({r['count_max']})"
                cells.append(s)
            lines.append(f"| {name} | " + " | ".join(cells) + " |")
    soup = metrics["polygon_soup"]
    p3, p4 = metrics["paper"]["table3"], metrics["paper"]["table4"]
    lines += ["", "## The paper's Tables 3 and 4 on today's tools", "",
              "Paper: RAPID on a Pentium IV at 1.5 GHz, timed with gprof over its 75,000-pattern test set. Its Table 3 "
              "column \"Triangles/face\" holds 12 N^2, the triangles of a whole box (2N^2 per face). Today: python-fcl "
              f"{env['packages'].get('python-fcl')} (FCL, OBBRSS trees), kernel = fcl.collide with every contact "
              "requested, over all pose sets here (\"typical\" = stacking and general only). The paper's MLP took "
              f"{PAPER_MLP_MS} ms per query.", "",
              "Table 3 (average time per query):", "",
              "| N | triangles/box | paper Table 3 avg [ms] | today avg kernel [ms] (typical) | today avg query [ms] |",
              "|---|---|---|---|---|"]
    for n, s in soup.items():
        ref = p3.get(n, {})
        lines.append(f"| {n} | {s['triangles_per_box']} | {_f(ref.get('avg_ms'))} | {_f(s['avg_kernel_ms'])} "
                     f"({_f(s['avg_kernel_ms_typical'])}) | {_f(s['avg_query_ms'])} |")
    lines += ["", "Table 4 (the pose with the most triangle tests). Paper \"Max. test\" counts RAPID's triangle "
              "tests; FCL does not expose its test counter, so today's columns give the colliding triangle pairs "
              "(exact) and the candidate pairs (triangle pairs whose axis-aligned bounds overlap: the leaf tests an "
              "ideal AABB tree must make).", "",
              "| N | paper max tests | paper worst [ms] | today max colliding pairs | kernel at that pose [ms] | "
              "today max candidate pairs | worst kernel [ms] | worst query [ms] |", "|---|---|---|---|---|---|---|---|"]
    for n, s in soup.items():
        ref = p4.get(n, {})
        lines.append(f"| {n} | {_f(ref.get('max_tests'), '{}')} | {_f(ref.get('worst_ms'))} | {s['max_colliding_pairs']} | "
                     f"{_f(s['kernel_ms_at_max_pairs'])} | {s['max_candidate_pairs']} | {_f(s['worst_kernel_ms'])} | "
                     f"{_f(s['worst_query_ms'])} |")
    ml = [(k, metrics["methods"][k]) for k in ("paper_mlp_single", "paper_mlp_batched", "improved_single",
                                                 "improved_batched")]
    lines += ["", "Learned models today (paper: about 0.5 ms per query):", ""]
    for k, v in ml:
        if v["available"]:
            t = v["all"]["time_us"]
            thr = v.get("throughput_us_per_pair")
            lines.append(f"- {k}: mean {_f(t['mean'] * 1e-3)} ms, max {_f(t['max'] * 1e-3)} ms per query"
                         + (f"; {_f(thr)} us per pair in batches of {v['throughput_batch']}" if thr else ""))
        else:
            lines.append(f"- {k}: not available ({v['reason']})")
    lines += ["", f"Wall time: {metrics['wall_time_s']['total']:.1f} s (labels {metrics['wall_time_s']['labels']:.1f} s).", ""]
    return "\n".join(lines)
