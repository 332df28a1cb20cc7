"""The applied-force effects in Bullet: wind, the deck's motion (with its twistlocks) and the crane.

Each is the effect's own law, evaluated here on Bullet's state at the step's start and handed to
pybullet as external forces before every stepSimulation (pybullet clears them after each step):

  wind         testbed/effects/wind.py's WindLaw: its force at C, the geometric centre (its moment
               about the COM through Bullet's torque path: no velocity-dependent part, and a body
               asleep stays so, as before this module)
  deck_motion  testbed/effects/deck/law.py's DeckMotionLaw (built by deck_motion.build_law, as
               Drake's DeckLoads and MuJoCo build it): per free body a force at its COM and a
               torque about it, both in D = Bullet's world, inertial loads plus twistlocks
  crane        testbed/effects/crane.py's RopeModel: the four rope forces at the top corner
               castings of the carried body, as one force at its COM and the torque of the four
               about it. The twistlocks release for good when the load is in contact and its C
               descends slower than seated_speed (t > 0), or at release_time; decided from the
               step's start state and the previous step's contacts, effective from the next step
               (testbed/engines/mujoco/crane.py's rule, Drake's CraneSystem's)

Forces go through applyExternalForce(..., WORLD_FRAME) at the body's COM. Torques do not go
through applyExternalTorque: Bullet's contact solver builds its friction rows from the velocities
plus the external force impulses but without the external torque impulses (it adds those after the
solve), so friction cannot hold a torque back within the step. An explicit torque that reverses a
rotation by more than twice its size in one step then grows without bound: the twistlocks' damping
in yaw on a 2-high stack of empty 1CC boxes (h c_yaw / I up to 2.85, measured: the stack spins up
within 20 ms), which Drake's and MuJoCo's implicit friction absorb. So a torque tau [N m] about the
COM enters as its impulse before the step, w += h I_W^-1 tau (I_W = R I_C R^T: the body's own
inertia), where the contact solve sees it as Drake's and MuJoCo's see their applied forces; the
same symplectic Euler update Bullet would make after the solve. A body under the deck's loads, and
the crane's load, never sleeps (model.py): Bullet's sleeping body ignores the forces.
"""

from __future__ import annotations

import numpy as np

from testbed.effects.crane import RopeModel
from testbed.effects.deck_motion import build_law as deck_law
from testbed.effects.wind import WindLaw
from testbed.geometry.rotations import rotation_from_quaternion
from testbed.physics import GRAVITY


class AppliedLoads:
    """The wind, deck and crane loads of one Bullet world (module doc).

    scenario: the (checked) Scenario; free: its free ContainerSpecs in Bullet's order; ids: their
    Bullet body ids; com_C (m, 3) [m] their COMs from C in C; inertia (m, 3) [kg m^2] their principal
    moments about the COM along C (model.BodyParams.inertia); h [s] the step; pb, cid: pybullet and
    the client."""

    def __init__(self, scenario, free, ids, com_C, inertia, h: float, pb, cid):
        self._pb, self._cid, self._ids, self._com_C = pb, cid, list(ids), np.asarray(com_C, float).reshape(-1, 3)
        self._inv_I, self._h = 1.0 / np.asarray(inertia, float).reshape(-1, 3), float(h)
        effects = scenario.effects
        self.wind = None if effects.wind is None else WindLaw(
            effects.wind, np.array([c.container_type().size for c in free], dtype=float).reshape(-1, 3))
        self.deck = None if effects.deck_motion is None else deck_law(
            effects.deck_motion, scenario, free, (0.0, 0.0, -GRAVITY))
        self.crane, self.release_time = None, None
        if effects.crane is not None:
            j = [c.name for c in free].index(effects.crane.container)
            self.crane = (j, RopeModel(effects.crane, free[j]), effects.crane)

    @property
    def active(self) -> bool:
        return self.wind is not None or self.deck is not None or self.crane is not None

    def apply(self, t: float, p_WC, q_WC, V_WC) -> None:
        """Applies every load at time t [s] for the state (p_WC (m, 3), q wxyz (m, 4), V_WC (m, 6)
        [w, v of C]) at the step's start; then updates the crane's twistlocks."""
        pb, cid = self._pb, self._cid
        R = rotation_from_quaternion(np.asarray(q_WC, float)).reshape(-1, 3, 3)
        p_WC = np.asarray(p_WC, float).reshape(-1, 3)
        com_W = p_WC + np.einsum("mij,mj->mi", R, self._com_C)
        force, torque = np.zeros((len(self._ids), 3)), np.zeros((len(self._ids), 3))  # at the COM, in W
        if self.wind is not None:  # at C, through Bullet's own torque path (a sleeping body stays asleep)
            for bid, f, p in zip(self._ids, self.wind.forces_W(R, t), p_WC):
                pb.applyExternalForce(bid, -1, f.tolist(), p.tolist(), pb.WORLD_FRAME, physicsClientId=cid)
        if self.deck is not None:
            rows = self.deck.wrenches_D(t, p_WC, R, V_WC[:, 3:], V_WC[:, :3])
            force += rows[:, :3]
            torque += rows[:, 3:]
        if self.crane is not None and self.release_time is None:
            j, ropes, config = self.crane
            f, p_BoC_W = ropes.corner_forces(t, R[j], p_WC[j], V_WC[j, 3:], V_WC[j, :3])  # (4, 3) each
            force[j] += f.sum(axis=0)
            torque[j] += np.cross(p_WC[j] + p_BoC_W - com_W[j], f).sum(axis=0)
            release = config.release_time is not None and t >= config.release_time
            if not release and config.release_time is None and t > 0:
                release = abs(V_WC[j, 5]) < config.seated_speed and self._touching(self._ids[j])
            if release:
                self.release_time = t
        # the torques' impulses, h I_W^-1 tau = h R (I_C^-1 (R^T tau)) (module doc)
        dw = self._h * np.einsum("mij,mj->mi", R, self._inv_I * np.einsum("mji,mj->mi", R, torque))
        for bid, f, c, spin, w_dot in zip(self._ids, force, com_W, dw, torque):
            if f.any():
                pb.applyExternalForce(bid, -1, f.tolist(), c.tolist(), pb.WORLD_FRAME, physicsClientId=cid)
            if w_dot.any():
                v, w = pb.getBaseVelocity(bid, physicsClientId=cid)
                pb.resetBaseVelocity(bid, v, (np.asarray(w) + spin).tolist(), physicsClientId=cid)

    def _touching(self, bid: int) -> bool:
        """Whether the last step left a touching contact point on body `bid` (run.py's rule)."""
        points = self._pb.getContactPoints(bodyA=bid, physicsClientId=self._cid)
        return any(c[8] <= 0.0 or c[9] > 0.0 for c in points)
