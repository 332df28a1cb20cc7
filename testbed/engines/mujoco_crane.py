"""The `crane` effect in MuJoCo: four tension-only ropes from a kinematic trolley, twistlocks.

The same model as testbed/effects/crane.py (its Profile gives the trolley position and rope
length over time; the rope law, static initial stretch, damping and release rule are those
of CraneSystem), applied to the carried body through xfrc_applied before every mj_step:
- rope i runs from the sheave (x_T(t) + sx, y_T + sy, trolley_height) to the top corner
  casting (sx, sy, h/2) of the container, sx = +-L/2, sy = +-W/2; tension
  T = max(0, (EA / L_r) (l - L_r) + c (dl/dt - dL/dt)), L_r = L0 + dL(t);
- the twistlocks release for good when the container is in contact and descends slower
  than seated_speed (t > 0), or at release_time. As in Drake, where the lock state is a
  discrete state updated at the step start from the previous step's contact results, a
  release decided at step k takes effect at step k + 1.
"""

from __future__ import annotations

import math

import numpy as np

from testbed.effects.crane import Profile
from testbed.physics import GRAVITY


class CraneRopes:
    """Rope forces on one MuJoCo body (see module). spec: the carried ContainerSpec."""

    def __init__(self, config, spec, model, body_id: int, geom_id: int, qadr: int, vadr: int):
        self._body, self._geom, self._qadr, self._vadr = body_id, geom_id, qadr, vadr
        half = spec.container_type().half_size
        self._p_BoC_B = np.array([[sx * half[0], sy * half[1], half[2]] for sx in (-1, 1) for sy in (-1, 1)])  # (4, 3)
        X_WC0 = spec.pose()
        p_WC0 = X_WC0.rotation().matrix() @ self._p_BoC_B.T + X_WC0.translation()[:, None]  # (3, 4)
        self._sheave_offsets = self._p_BoC_B[:, :2].copy()
        self._y_T, self._height = X_WC0.translation()[1], config.trolley_height
        length0 = self._height - p_WC0[2].mean()
        mass = spec.total_mass()
        self._EA = config.rope_EA
        self._L0 = length0 - mass * GRAVITY / 4.0 / (self._EA / length0)
        self._c = 2.0 * config.rope_damping_ratio * math.sqrt(4.0 * self._EA / length0 * mass) / 4.0
        self._profile = Profile(config.moves, X_WC0.translation()[0])
        self._seated_speed, self._release_time = config.seated_speed, config.release_time
        self._com_B = np.asarray(spec.com_offset, dtype=float)
        self.release_time: float | None = None  # [s] when the twistlocks opened

    def _in_contact(self, data) -> bool:
        n = data.ncon
        if n == 0:
            return False
        con = data.contact
        live = np.array(con.efc_address[:n]) >= 0
        return bool(np.any(live & ((np.array(con.geom1[:n]) == self._geom) | (np.array(con.geom2[:n]) == self._geom))))

    def apply(self, data, R_WB: np.ndarray) -> None:
        """Adds this step's rope wrench (at the COM, in W) to xfrc_applied, then updates the
        locks from the state and the previous step's contacts (R_WB (3, 3): current pose)."""
        t = data.time
        if self.release_time is None:
            p_WBo = data.qpos[self._qadr:self._qadr + 3]
            v_WBo = data.qvel[self._vadr:self._vadr + 3]
            w_W = R_WB @ data.qvel[self._vadr + 3:self._vadr + 6]
            x_T, v_T, dl, dl_dot = self._profile(t)
            p_BoC_W = self._p_BoC_B @ R_WB.T  # (4, 3)
            v_WC = v_WBo + np.cross(w_W, p_BoC_W)
            sheaves = np.column_stack([x_T + self._sheave_offsets[:, 0], self._y_T + self._sheave_offsets[:, 1],
                                       np.full(4, self._height)])
            rope = sheaves - (p_WBo + p_BoC_W)
            length = np.linalg.norm(rope, axis=1)
            u = rope / length[:, None]
            length_dot = np.einsum("ij,ij->i", np.array([v_T, 0.0, 0.0]) - v_WC, u)
            rest = self._L0 + dl
            tension = np.maximum(0.0, self._EA / rest * (length - rest) + self._c * (length_dot - dl_dot))  # (4,) [N]
            f = tension[:, None] * u  # (4, 3) at the corners
            p_cm_C_W = p_BoC_W - R_WB @ self._com_B  # corners from the COM
            data.xfrc_applied[self._body, :3] += f.sum(axis=0)
            data.xfrc_applied[self._body, 3:] += np.cross(p_cm_C_W, f).sum(axis=0)
            release = self._release_time is not None and t >= self._release_time
            if not release and self._release_time is None and t > 0:
                release = abs(data.qvel[self._vadr + 2]) < self._seated_speed and self._in_contact(data)
            if release:
                self.release_time = t
