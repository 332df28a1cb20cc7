"""Numba glue between MuJoCo's data arrays and the learned-contact kernels (one call each per
step; the force law itself is testbed/effects/learned_dynamics/kernels.py's). Compiled with
cache=True."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def body_state(xpos, xmat, qvel, body, dof, free):
    """(p (m, 3) [m], R (m, 3, 3), w (m, 3) [rad/s], v (m, 3) [m/s]) of the containers' body
    origins C in W. xpos (nbody, 3), xmat (nbody, 9): MuJoCo's body poses (after mj_step1);
    qvel (nv,): free joints' [v_W of C, w in C]; body (m,) body ids; dof (m,) the first dof
    of each free container's joint (-1 if fixed); free (m,) bool."""
    m = len(body)
    p, R = np.empty((m, 3)), np.empty((m, 3, 3))
    w, v = np.zeros((m, 3)), np.zeros((m, 3))
    for i in range(m):
        b = body[i]
        for a in range(3):
            p[i, a] = xpos[b, a]
            for c in range(3):
                R[i, a, c] = xmat[b, 3 * a + c]
        if free[i]:
            d = dof[i]
            for a in range(3):
                v[i, a] = qvel[d + a]
                acc = 0.0
                for c in range(3):
                    acc += R[i, a, c] * qvel[d + 3 + c]
                w[i, a] = acc
    return p, R, w, v


@njit(cache=True)
def write_wrenches(xfrc, out, body, free, xpos, xipos):
    """xfrc_applied (nbody, 6) [force, torque about the COM, in W] of each free container from
    out (m, 6) [torque about the body origin C, force, in W]; the other rows zeroed."""
    xfrc[:] = 0.0
    for i in range(len(body)):
        if not free[i]:
            continue
        b = body[i]
        f0, f1, f2 = out[i, 3], out[i, 4], out[i, 5]
        r0, r1, r2 = xipos[b, 0] - xpos[b, 0], xipos[b, 1] - xpos[b, 1], xipos[b, 2] - xpos[b, 2]
        xfrc[b, 0], xfrc[b, 1], xfrc[b, 2] = f0, f1, f2
        xfrc[b, 3] = out[i, 0] - (r1 * f2 - r2 * f1)
        xfrc[b, 4] = out[i, 1] - (r2 * f0 - r0 * f2)
        xfrc[b, 5] = out[i, 2] - (r0 * f1 - r1 * f0)
