"""Drake labels for container pairs: static hydroelastic answer and point contact.

For each proposal (sampling.py) a worker process places A at the origin and B at
p_AB = base + s u, bisecting s with Drake's signed distance until the penetration
depth equals the target, then asks the QueryObject (not a sampled output port) for
- ComputeContactSurfaces(kPolygon) -> testbed.contact.surfaces.static_pressure:
  centre of pressure (the exact integral of Drake's pressure field over Drake's contact
  surface) and pressure-weighted normal, turned to point from A towards B; beside it the
  one-point rule's centre of pressure (each polygon at its centroid: what Drake's discrete
  solver applies), the named second reference;
- ComputePointPairPenetration: Drake's point-contact point (midpoint of the two
  witness points), normal A->B and depth.
A sits at the world origin, so world quantities are A-frame quantities.

Each worker builds one two-body MultibodyPlant per ordered type pair (lazily, at most
9) and only sets poses per sample. Results are cached on disk (cache.py), keyed by
distribution, n, seed, types and LABEL_VERSION.
"""

from __future__ import annotations

import dataclasses
import multiprocessing
import os

import numpy as np

from learned_contact.data import cache
from learned_contact.data.sampling import Proposals, sample
from learned_contact.model.prior import contact_type
from testbed.drake_support import drake_version
from testbed.progress import progress as progress_bar

LABEL_VERSION = 4  # bump when labelling or sampling changes meaning (2: forces at the 1e9 Pa SDF modulus;
# 3: the centre of pressure is the exact integral, the one-point rule's beside it;
# 4: the weighted sums are numpy reductions, not BLAS: the same bits on every CPU)
_BISECT_TOL = 1e-6  # [m]
LABEL_MODULUS = 1e9  # [Pa] both boxes' hydroelastic modulus when labelled (the shipped SDF's)

# Per-process state: (type_a, type_b) -> testbed.contact.pair_plant.ContainerPair
_SCENES: dict = {}


def pair_scene(type_a: str, type_b: str):
    """The per-process two-container plant for (type_a, type_b) (testbed.contact.pair_plant)."""
    key = (type_a, type_b)
    if key not in _SCENES:
        from testbed.contact.pair_plant import ContainerPair

        _SCENES[key] = ContainerPair(type_a, type_b)
    return _SCENES[key]


def posed_query(scene, R, p):
    """Drake's QueryObject of a pair scene with B posed at (p (3,) [m], R (3, 3)) in A."""
    return scene.set_pose(p, R)


def _signed_distance(scene, R, p) -> float:
    q = posed_query(scene, R, p)
    return q.ComputeSignedDistancePairClosestPoints(scene.gid_a, scene.gid_b).distance


def label_one(type_a: str, type_b: str, R_AB, base, direction, depth) -> np.ndarray:
    """Labels one proposal. Returns a (LABEL_WIDTH,) row (see LABEL_FIELDS); NaNs when
    Drake reports no contact surface."""
    from pydrake.geometry import HydroelasticContactRepresentation

    from testbed.contact.surfaces import static_pressure, surface_face_arrays

    scene = pair_scene(type_a, type_b)
    R_AB = np.asarray(R_AB)
    lo, hi = 0.0, 30.0  # [m] along direction; lo is deeply overlapping, hi separated
    while _signed_distance(scene, R_AB, base + hi * direction) < 0:
        hi *= 2.0
    while hi - lo > _BISECT_TOL:
        mid = 0.5 * (lo + hi)
        if _signed_distance(scene, R_AB, base + mid * direction) < -depth:
            lo = mid
        else:
            hi = mid
    p_AB = base + hi * direction
    q = posed_query(scene, R_AB, p_AB)
    signed = q.ComputeSignedDistancePairClosestPoints(scene.gid_a, scene.gid_b).distance
    row = np.full(LABEL_WIDTH, np.nan)
    row[0:3] = p_AB
    row[3] = -signed
    surfaces = q.ComputeContactSurfaces(HydroelasticContactRepresentation.kPolygon)
    if surfaces:
        surface = surfaces[0]
        faces = surface_face_arrays(surface)
        sp = static_pressure(faces)
        # face normals point out of N into M: A->B when M is B.
        flip = 1.0 if surface.id_M() == scene.gid_b else -1.0
        row[4:7] = sp.cop
        row[7:10] = flip * sp.normal
        row[10:13] = flip * sp.force  # elastic force on B [N]
        row[13] = sp.area
        row[14] = len(faces.area)
        row[22:25] = sp.cop_one_point
    pairs = q.ComputePointPairPenetration()
    if pairs:
        pp = pairs[0]
        # nhat_BA_W points out of Drake's B into Drake's A.
        flip = -1.0 if pp.id_A == scene.gid_a else 1.0
        row[15:18] = 0.5 * (pp.p_WCa + pp.p_WCb)
        row[18:21] = flip * pp.nhat_BA_W
        row[21] = pp.depth
    return row


LABEL_FIELDS = {
    "p_AB": slice(0, 3),  # (3,) B's centre in A [m]
    "depth": slice(3, 4),  # penetration depth from signed distance [m]
    "cop": slice(4, 7),  # centre of pressure in A [m]
    "normal": slice(7, 10),  # pressure-weighted unit normal A->B
    "force": slice(10, 13),  # elastic force on B in A [N]
    "area": slice(13, 14),  # contact surface area [m^2]
    "n_faces": slice(14, 15),
    "pp_point": slice(15, 18),  # point contact: midpoint of witness points [m]
    "pp_normal": slice(18, 21),  # point contact: unit normal A->B
    "pp_depth": slice(21, 22),  # point contact depth [m]
    "cop_one_point": slice(22, 25),  # Drake's one-point rule's centre of pressure in A [m]
}
LABEL_WIDTH = 25


def _label_chunk(args) -> np.ndarray:
    types, type_a, type_b, R, base, direction, depth = args
    return np.array([
        label_one(types[a], types[b], R[i], base[i], direction[i], depth[i])
        for i, (a, b) in enumerate(zip(type_a, type_b))
    ]).reshape(len(depth), LABEL_WIDTH)


def label_proposals(props: Proposals, *, workers: int = 2, progress: bool = True,
                    chunk: int = 200) -> np.ndarray:
    """(n, LABEL_WIDTH) labels of all proposals, in order, using `workers` processes."""
    jobs = [
        (props.types, props.type_a[i:i + chunk], props.type_b[i:i + chunk], props.R_AB[i:i + chunk],
         props.base[i:i + chunk], props.direction[i:i + chunk], props.depth[i:i + chunk])
        for i in range(0, len(props), chunk)
    ]

    bar = progress_bar(total=len(props), desc="labelling", unit="pose", disable=not progress)
    out = []
    if workers <= 1:
        for job in jobs:
            out.append(_label_chunk(job))
            bar.update(len(job[-1]))
    else:
        import concurrent.futures

        # A process pool that fails loudly (BrokenProcessPool) if a worker dies, where
        # multiprocessing.Pool.imap would wait forever for the lost chunk.
        ctx = multiprocessing.get_context("spawn" if os.name == "nt" else "forkserver")
        with concurrent.futures.ProcessPoolExecutor(workers, mp_context=ctx) as pool:
            for rows in pool.map(_label_chunk, jobs):
                out.append(rows)
                bar.update(len(rows))
    bar.close()
    return np.concatenate(out, axis=0)


@dataclasses.dataclass(frozen=True)
class Dataset:
    """Labelled poses (only those with a contact surface). Arrays in A's frame.

    p_AB (n, 3) [m]; R_AB (n, 3, 3); size_A, size_B (n, 3) full extents [m];
    cop (n, 3) [m] the exact centre of pressure; cop_one_point (n, 3) [m] the one-point
    rule's (what Drake's discrete solver applies); normal (n, 3) unit A->B; depth (n,) [m]; tag (n,) index into
    geometry.CONTACT_TYPES; pp_point (n, 3) [m], pp_normal (n, 3), pp_depth (n,) [m]:
    Drake's point-contact answer. n_dropped: proposals without a contact surface. force (n, 3) [N]:
    Drake's static elastic force on B at the pose (both boxes compliant at LABEL_MODULUS; the force
    is linear in the modulus), None where a Dataset was built without it.
    """

    distribution: str
    p_AB: np.ndarray
    R_AB: np.ndarray
    size_A: np.ndarray
    size_B: np.ndarray
    cop: np.ndarray
    normal: np.ndarray
    depth: np.ndarray
    area: np.ndarray
    tag: np.ndarray
    pp_point: np.ndarray
    pp_normal: np.ndarray
    pp_depth: np.ndarray
    cop_one_point: np.ndarray
    n_dropped: int
    force: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.depth)

    def subset(self, idx) -> "Dataset":
        fields = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        return Dataset(**{k: (v[idx] if isinstance(v, np.ndarray) else v) for k, v in fields.items()})


def make_dataset(distribution: str, n: int, seed: int, *, types=("1CC", "1AA", "1AAA"),
                 workers: int = 2, progress: bool = True, use_cache: bool = True, **ranges) -> Dataset:
    """Samples n proposals, labels them with Drake (cached on disk) and returns the
    Dataset of those with a contact surface. ranges: sampling.sample's max_depth /
    max_tilt_deg (default: the training ranges)."""
    # the installed Drake's version too: labels are Drake's numerics (1.51.1 and 1.58.0 gave
    # bitwise-equal labels on 3000 poses, but one cache serves both interpreters)
    key = cache.key("labels", distribution, n, seed, tuple(types), LABEL_VERSION, drake_version(), *sorted(ranges.items()))
    rows = cache.load(key) if use_cache else None
    props = sample(distribution, n, seed, types, **ranges)
    if rows is None:
        rows = label_proposals(props, workers=workers, progress=progress)
        if use_cache:
            cache.save(key, rows)
    size_A, size_B = props.sizes()
    ok = np.isfinite(rows[:, 4]) & np.isfinite(rows[:, 7])
    get = lambda name: rows[:, LABEL_FIELDS[name]]  # noqa: E731
    p_AB = get("p_AB")
    tag = contact_type(p_AB, props.R_AB, 0.5 * size_A, 0.5 * size_B)
    ds = Dataset(
        distribution=distribution, p_AB=p_AB, R_AB=props.R_AB, size_A=size_A, size_B=size_B,
        cop=get("cop"), normal=get("normal"), depth=get("depth")[:, 0], area=get("area")[:, 0],
        tag=tag, pp_point=get("pp_point"), pp_normal=get("pp_normal"), pp_depth=get("pp_depth")[:, 0],
        cop_one_point=get("cop_one_point"), n_dropped=0, force=get("force"),
    )
    ds = ds.subset(ok)
    return dataclasses.replace(ds, n_dropped=int((~ok).sum()))
