"""The `crane` effect in MuJoCo: four tension-only ropes from a kinematic trolley, twistlocks.

The same model as testbed/effects/crane.py (its RopeModel: trolley profile, rope law,
static initial stretch and damping; the release rule is CraneSystem's), applied to the carried body through xfrc_applied before every mj_step:
- rope i runs from the sheave (x_T(t), y_T, trolley_height) + R_q (sx, sy, 0) to the top
  corner casting (sx, sy, h/2) of the container, sx = +-L/2, sy = +-W/2, R_q the quarter
  turn nearest the container's initial yaw (RopeModel); tension
  T = max(0, (EA / L_r) (l - L_r) + c (dl/dt - dL/dt)), L_r = L0 + dL(t);
- the twistlocks release for good when the container is in contact and descends slower
  than seated_speed (t > 0), or at release_time. As in Drake, where the lock state is a
  discrete state updated at the step start from the previous step's contact results, a
  release decided at step k takes effect at step k + 1.
"""

from __future__ import annotations

import numpy as np

from testbed.effects.crane import RopeModel


class CraneRopes:
    """Rope forces on one MuJoCo body (see module). spec: the carried ContainerSpec."""

    def __init__(self, config, spec, model, body_id: int, geom_id: int, qadr: int, vadr: int):
        self._body, self._geom, self._qadr, self._vadr = body_id, geom_id, qadr, vadr
        self._ropes = RopeModel(config, spec)
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
            f, p_BoC_W = self._ropes.corner_forces(t, R_WB, p_WBo, v_WBo, w_W)  # (4, 3) each, in W
            p_cm_C_W = p_BoC_W - R_WB @ self._com_B  # corners from the COM
            data.xfrc_applied[self._body, :3] += f.sum(axis=0)
            data.xfrc_applied[self._body, 3:] += np.cross(p_cm_C_W, f).sum(axis=0)
            release = self._release_time is not None and t >= self._release_time
            if not release and self._release_time is None and t > 0:
                release = abs(data.qvel[self._vadr + 2]) < self._seated_speed and self._in_contact(data)
            if release:
                self.release_time = t
