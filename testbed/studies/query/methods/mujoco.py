"""Query-study method of MuJoCo: its box-box collision, reduced to one point and normal.

An MjModel holds two free bodies, each with one box geom: A (geom 0) at the world
origin, B (geom 1) posed per query, so the world frame is A's frame. Per query B's
free-joint coordinates are written, `mj_kinematics` places the geoms and
`mj_collision` runs MuJoCo's box-box routine, which returns up to 8 contacts.
Contact i has position pos (3,) [m], dist [m] (negative = penetration) and frame
rows 0..2 = normal pointing from geom1 to geom2. Geoms are ordered A, B, so that
normal points from A into B.

Reduction to one answer: point = mean of the contact positions weighted by depth
(-dist; equal weights when all depths are zero), normal = normalised depth-weighted
mean of the contact normals, turned to point from A to B.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from testbed.errors import OptionalDependencyError
from testbed.studies.query.methods.base import ContactMethod, missing

ORDER = 30
LABEL = "MuJoCo box-box (mj_collision)"


def _mujoco():
    try:
        import mujoco
    except ImportError:  # pragma: no cover - depends on the environment
        raise OptionalDependencyError("mujoco", "MuJoCo's box-box collision in the query study", "study") from None
    return mujoco


class MujocoAnswer(NamedTuple):
    """point (3,) [m], unit normal (3,) A->B, in A's frame (NaN without contact);
    n_contacts: contacts MuJoCo returned."""

    point: np.ndarray
    normal: np.ndarray
    n_contacts: int


class MujocoBoxPair:
    """Two boxes of full extents size_A, size_B (3,) [m] in one MjModel (see module)."""

    def __init__(self, size_A, size_B):
        mj = _mujoco()
        self._mj = mj
        ha, hb = 0.5 * np.asarray(size_A, dtype=float), 0.5 * np.asarray(size_B, dtype=float)
        fmt = lambda h: " ".join(repr(float(x)) for x in h)  # noqa: E731
        xml = f"""<mujoco model="box_pair">
  <option><flag gravity="disable"/></option>
  <worldbody>
    <body name="A"><freejoint/><geom name="A" type="box" size="{fmt(ha)}"/></body>
    <body name="B"><freejoint/><geom name="B" type="box" size="{fmt(hb)}"/></body>
  </worldbody>
</mujoco>"""
        self.model = mj.MjModel.from_xml_string(xml)
        self.data = mj.MjData(self.model)
        self.data.qpos[:7] = [0, 0, 0, 1, 0, 0, 0]
        self._quat = np.zeros(4)

    def set_pose(self, p_AB, R_AB) -> None:
        """Places B at p_AB (3,) [m], R_AB (3, 3) in A's frame and updates kinematics."""
        mj = self._mj
        mj.mju_mat2Quat(self._quat, np.ascontiguousarray(R_AB, dtype=float).ravel())
        self.data.qpos[7:10] = p_AB
        self.data.qpos[10:14] = self._quat
        mj.mj_kinematics(self.model, self.data)

    def collide(self) -> int:
        """MuJoCo's collision call alone (the 'kernel'): returns the number of contacts."""
        self._mj.mj_collision(self.model, self.data)
        return int(self.data.ncon)

    def query(self, p_AB, R_AB) -> MujocoAnswer:
        """Pose in, reduced contact point and normal out."""
        self.set_pose(p_AB, R_AB)
        k = self.collide()
        if k == 0:
            nan3 = np.full(3, np.nan)
            return MujocoAnswer(nan3, nan3, 0)
        con = self.data.contact
        pos = np.array(con.pos[:k])  # (k, 3) [m]
        nrm = np.array(con.frame[:k, :3])  # (k, 3) geom1 -> geom2
        flip = np.where(np.array(con.geom1[:k]) == 0, 1.0, -1.0)[:, None]  # A is geom 0
        w = np.maximum(-np.array(con.dist[:k]), 0.0)
        if w.sum() <= 0.0:
            w = np.ones(k)
        point = w @ pos / w.sum()
        direction = w @ (flip * nrm)
        return MujocoAnswer(point, direction / np.linalg.norm(direction), k)


def build(poses, scenes, options) -> list[ContactMethod]:
    """mujoco, or mujoco marked unavailable when the package is missing."""
    reason = missing("mujoco", "mujoco")
    if reason:
        return [ContactMethod("mujoco", LABEL, "mujoco", False, reason)]
    P, R, SA, SB = poses.p_AB, poses.R_AB, poses.size_A, poses.size_B

    def scene(i):
        a, b = tuple(SA[i]), tuple(SB[i])
        return scenes.get(("mujoco", a, b), lambda: MujocoBoxPair(a, b))

    def single(i):
        answer = scene(i).query(P[i], R[i])
        return answer.point, answer.normal, answer.n_contacts

    def prepare_kernel(i):
        pair = scene(i)
        pair.set_pose(P[i], R[i])
        return pair.collide

    return [ContactMethod("mujoco", LABEL, "mujoco", single=single, prepare_kernel=prepare_kernel)]
