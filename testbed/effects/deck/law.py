"""DeckMotionLaw: the deck motion's inertial wrenches and the twistlocks, for k free bodies.

All vectors are in the deck frame D, the plant's world (testbed/effects/deck/motion.py).
Per free body, with mass m, COM position r from the pivot P, COM velocity v and angular
velocity w (both relative to D), rotational inertia I about the COM (in D):

  F   = m (g_D - g) - m [a_P + alpha x r + Omega x (Omega x r) + 2 Omega x v]
  tau = -I alpha - Omega x (I Omega) - [Omega x (I w) + w x (I Omega) + I (Omega x w)]

g is the gravity the engine already applies in D (kept: the law adds only the difference to
g_D = R_WD^T g, gravity rotated into the deck). The torque is the rotating-frame Euler
equation: with the body's inertial angular velocity Omega + w and I changing in D as
dI/dt = [w]x I - I [w]x, d(I(Omega + w))/dt|_W = tau_real gives
I w' + w x (I w) = tau_real + tau above. (A uniform sphere: tau = -i (alpha + Omega x w),
the transport term of dw/dt|_W = dw/dt|_D + Omega x w.)

Twistlocks (locked): each lock joins a corner casting of an upper body A to the point of the
lower body B (or of the deck) it sat on at t = 0, with a spring-damper acting in shear (the
components of the gap d = q_A - q_B normal to B's z axis n) and in tension only (d.n > 0,
pulling, never pushing: contact carries compression):
  f_A = -k d_t - c v_t + min(0, -k d_n - c v_n) n   (when d_n > 0; else no normal part),
applied at q_A to A and, opposite, to B.
"""

from __future__ import annotations

import numpy as np

from testbed.bodies.boxes import BOX_TYPE
from testbed.bodies.models import solid_box_inertia
from testbed.effects.deck.motion import DeckMotion

STACK_GAP = 5e-3  # [m] a bottom face within this of a top face (or the deck) sits on it
CORNER_REACH = 0.05  # [m] a corner casting may lie this far outside the lower box's footprint


def mass_properties(specs) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(masses (k,) [kg], com_C (k, 3) [m] COM from the geometric centre in C, I_C (k, 3, 3)
    [kg m^2] about the COM along C) of scene container specs (testbed.scenario.ContainerSpec),
    as testbed/bodies/models.py writes them into the SDF: a uniform solid box, or a box's given moments."""
    masses = np.array([s.total_mass() for s in specs], float)
    com = np.array([s.com_offset for s in specs], float).reshape(-1, 3)
    inertia = np.zeros((len(specs), 3, 3))
    for i, s in enumerate(specs):
        size = s.container_type().size
        given = s.box.inertia if s.type == BOX_TYPE and s.box is not None and s.box.inertia else None
        inertia[i] = np.diag(given if given is not None else solid_box_inertia(masses[i], size))
    return masses, com, inertia


def find_locks(specs, deck_z: float | None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The twistlocks of scene specs (all containers, fixed included) at their t = 0 poses:
    (upper (n,) index into specs, lower (n,) index or -1 for the deck or a fixed body,
    p_A (n, 3) the corner in the upper body's frame C [m], p_B (n, 3) the same point in the
    lower body's frame C, or in D for -1). A free, upright body's four bottom corners are each
    locked to the body whose top face lies within STACK_GAP of it and whose footprint holds the
    corner (within CORNER_REACH), else to the deck (deck_z: its top face z in D; None: no deck)."""
    poses = [s.pose() for s in specs]
    R = np.array([X.rotation().matrix() for X in poses]).reshape(-1, 3, 3)
    p = np.array([X.translation() for X in poses], float).reshape(-1, 3)
    half = np.array([s.container_type().half_size for s in specs], float).reshape(-1, 3)
    upright = R[:, 2, 2] > 1 - 1e-6
    top = p[:, 2] + half[:, 2]
    signs = np.array([[sx, sy, -1.0] for sx in (-1, 1) for sy in (-1, 1)])
    upper, lower, p_A, p_B = [], [], [], []
    for a, spec in enumerate(specs):
        if spec.fixed or not upright[a]:
            continue
        for corner_C in signs * half[a]:
            q = p[a] + R[a] @ corner_C
            found = None
            for b in range(len(specs)):
                if b == a or not upright[b] or abs(q[2] - top[b]) > STACK_GAP:
                    continue
                local = R[b].T @ (q - p[b])
                if np.all(np.abs(local[:2]) <= half[b, :2] + CORNER_REACH):
                    found = b
                    break
            if found is not None:
                upper.append(a)
                lower.append(-1 if specs[found].fixed else found)
                p_B.append(q if specs[found].fixed else R[found].T @ (q - p[found]))
                p_A.append(corner_C)
            elif deck_z is not None and abs(q[2] - deck_z) <= STACK_GAP:
                upper.append(a)
                lower.append(-1)
                p_A.append(corner_C)
                p_B.append(q)
    return (np.array(upper, int), np.array(lower, int), np.array(p_A, float).reshape(-1, 3),
            np.array(p_B, float).reshape(-1, 3))


class DeckMotionLaw:
    """The wrenches of the module docstring on k free bodies, the one statement of the law:
    Drake's DeckLoads and both MuJoCo engines call it.

    motion: the DeckMotion; gravity (3,) [m/s^2] the engine's own gravity in D; masses (k,)
    [kg], com_C (k, 3) [m], I_C (k, 3, 3) [kg m^2] (mass_properties); locks: find_locks's
    arrays with indices into the k free bodies (-1: the deck), or None (open twistlocks);
    stiffness [N/m] and damping [N s/m] of each lock."""

    def __init__(self, motion: DeckMotion, gravity, masses, com_C, I_C, locks=None,
                 stiffness: float = 0.0, damping: float = 0.0):
        self.motion = motion
        self.gravity = np.asarray(gravity, float).reshape(3)
        self.masses = np.asarray(masses, float).reshape(-1)
        self.com_C = np.asarray(com_C, float).reshape(-1, 3)
        self.I_C = np.asarray(I_C, float).reshape(-1, 3, 3)
        empty = (np.zeros(0, int), np.zeros(0, int), np.zeros((0, 3)), np.zeros((0, 3)))
        self.upper, self.lower, self.p_A, self.p_B = empty if locks is None else locks
        self.k, self.c = float(stiffness), float(damping)

    def inertial_wrenches(self, t: float, p_DC, R_DC, v_DC, w_D) -> np.ndarray:
        """(k, 6) rows [force (3) N, torque about the COM (3) N m] in D of the deck's motion
        at t [s] on bodies whose frames C have poses p_DC (k, 3) [m], R_DC (k, 3, 3), origin
        velocities v_DC (k, 3) [m/s] and angular velocities w_D (k, 3) [rad/s], all relative to D."""
        out = np.zeros((len(self.masses), 6))
        if self.motion.at_rest:
            return out  # exactly nothing: the deck is the world
        d = self.motion.state(t)
        p_CCm = np.einsum("kij,kj->ki", R_DC, self.com_C)  # COM from C, in D
        r = p_DC + p_CCm - self.motion.pivot
        v = v_DC + np.cross(w_D, p_CCm)
        W, A = d.Omega_D, d.alpha_D
        g_D = d.R_WD.T @ self.gravity
        accel = d.a_P_D + np.cross(A, r) + np.cross(W, np.cross(W, r)) + 2 * np.cross(W, v)
        out[:, :3] = self.masses[:, None] * (g_D - self.gravity - accel)
        I = np.einsum("kij,kjl,kml->kim", R_DC, self.I_C, R_DC)  # about the COM, in D
        I_W = I @ W  # (k, 3) I Omega
        out[:, 3:] = -(I @ A + np.cross(W, I_W) + np.cross(W, np.einsum("kij,kj->ki", I, w_D))
                       + np.cross(w_D, I_W) + np.einsum("kij,kj->ki", I, np.cross(W, w_D)))
        return out

    def lock_wrenches(self, p_DC, R_DC, v_DC, w_D) -> np.ndarray:
        """(k, 6) rows [force, torque about the COM] in D of the twistlocks (module docstring)."""
        out = np.zeros((len(self.masses), 6))
        if not len(self.upper):
            return out
        a, b = self.upper, self.lower
        on_body = b >= 0
        bb = np.where(on_body, b, 0)
        arm_A = np.einsum("nij,nj->ni", R_DC[a], self.p_A)
        q_A, v_A = p_DC[a] + arm_A, v_DC[a] + np.cross(w_D[a], arm_A)
        arm_B = np.einsum("nij,nj->ni", R_DC[bb], self.p_B)
        q_B = np.where(on_body[:, None], p_DC[bb] + arm_B, self.p_B)
        v_B = np.where(on_body[:, None], v_DC[bb] + np.cross(w_D[bb], arm_B), 0.0)
        n = np.where(on_body[:, None], R_DC[bb][:, :, 2], np.array([0.0, 0.0, 1.0]))
        gap, rate = q_A - q_B, v_A - v_B
        d_n, v_n = np.einsum("ni,ni->n", gap, n), np.einsum("ni,ni->n", rate, n)
        f = -self.k * (gap - d_n[:, None] * n) - self.c * (rate - v_n[:, None] * n)
        pull = np.where(d_n > 0, np.minimum(0.0, -self.k * d_n - self.c * v_n), 0.0)
        f += pull[:, None] * n
        com = p_DC + np.einsum("kij,kj->ki", R_DC, self.com_C)  # (k, 3) COMs in D
        np.add.at(out, (a, slice(0, 3)), f)
        np.add.at(out, (a, slice(3, 6)), np.cross(q_A - com[a], f))
        np.add.at(out, (b[on_body], slice(0, 3)), -f[on_body])
        np.add.at(out, (b[on_body], slice(3, 6)), np.cross(q_A[on_body] - com[b[on_body]], -f[on_body]))
        return out

    def wrenches_D(self, t: float, p_DC, R_DC, v_DC, w_D) -> np.ndarray:
        """(k, 6) [force N, torque about the COM N m] in D: inertial wrenches plus twistlocks;
        arguments as inertial_wrenches."""
        args = [np.asarray(x, float) for x in (p_DC, R_DC, v_DC, w_D)]
        args[1] = args[1].reshape(-1, 3, 3)
        return self.inertial_wrenches(t, *args) + self.lock_wrenches(*args)

    def power_W(self, t: float, p_DC, R_DC, v_DC, w_D) -> float:
        """[W] the power of wrenches_D (the deck's inertial wrenches and the twistlocks) on the k
        bodies at t [s], arguments as inertial_wrenches (in D): force . COM velocity plus
        torque . angular velocity, summed. Its integral is the work the moving deck (and the
        locks' springs and dampers) does on the bodies in D, where the plant's energy is measured."""
        p_DC, R_DC, v_DC, w_D = (np.asarray(x, float) for x in (p_DC, R_DC, v_DC, w_D))
        R_DC = R_DC.reshape(-1, 3, 3)
        rows = self.wrenches_D(t, p_DC, R_DC, v_DC, w_D)
        w_D = w_D.reshape(-1, 3)
        v_com = v_DC.reshape(-1, 3) + np.cross(w_D, np.einsum("kij,kj->ki", R_DC, self.com_C))
        return float(np.einsum("ki,ki->", rows[:, :3], v_com) + np.einsum("ki,ki->", rows[:, 3:], w_D))

    def mujoco_rows(self, qpos, qvel, t: float) -> np.ndarray:
        """(k, 6) rows of MuJoCo's xfrc_applied [force, torque about the COM, in D = MuJoCo's
        world] from the free joints' qpos (k, 7) [position of C, quaternion w x y z] and qvel
        (k, 6) [velocity of C in the world, angular velocity in C]."""
        qpos, qvel = np.asarray(qpos, float).reshape(-1, 7), np.asarray(qvel, float).reshape(-1, 6)
        w, x, y, z = (qpos[:, 3 + i] / np.linalg.norm(qpos[:, 3:], axis=1) for i in range(4))
        R = np.stack([
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], axis=-1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], axis=-1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=-1)], axis=1)
        return self.wrenches_D(t, qpos[:, :3], R, qvel[:, :3], np.einsum("kij,kj->ki", R, qvel[:, 3:]))
