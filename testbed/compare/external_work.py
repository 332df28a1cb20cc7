"""The work external actors do on a run's free containers, integrated over its records.

An external actor is a PHYSICS effect that pushes the containers from outside the contact
model: the wind (testbed/effects/wind.py), a crane's ropes (crane.py), the moving deck and its
twistlocks (deck_motion.py). Each says so with an `external_power()` method returning its power
[W] as a pure function of one record (t, p_WB, R_WB, v_WB, w_WB: the free containers' poses and
body-origin velocities in the plant's world, scene order), built from the very law object the
simulation applies (no second copy of a formula), or None where the records cannot give it.

W(t) [J] is the trapezoidal integral of the summed power over the record times. The energy the
contact model (contact and friction) put in is then C(t) = E(t) - E(0) - W(t): <= 0 for passive
contact, up to the integration error of sampling the power at the record period (the compare
path records every 10 ms, ten 1 ms plant steps; tests/closed_loop/test_external_work.py measures
that error and the closed-loop gate, testbed/gates/closed_loop.py, reads C).

Why here, where the records are written (artifacts.write_series), rather than in the gate: the
records hold the state but not the scene that ran (its `--set` overrides, a derived variant),
and the gates are keyed by a scene's name alone; the writer has the very Scenario of the run.
"""

from __future__ import annotations

import numpy as np

from testbed.geometry.rotations import rotation_from_quaternion
from testbed.scenario import checked_effects


def power_laws(scenario) -> list | None:
    """[(effect name, power(t, p, R, v, w) -> W)] of `scenario`'s external actors ([]: none),
    or None when one of them cannot be evaluated from records (a crane releasing on seating)."""
    laws = []
    for name, effect in checked_effects(scenario).items():
        make = getattr(effect, "external_power", None)
        if make is None:
            continue
        power = make()
        if power is None:
            return None
        laws.append((name, power))
    return laws


def external_work(laws, traj) -> np.ndarray:
    """(n,) [J] the work W(t) of `laws` (power_laws) on the run `traj` (a Trajectory: time
    (n,) [s], p_WB (n, m, 3), q_WB (n, m, 4) w x y z, V_WB (n, m, 6) [angular, linear]) from its
    first record to each: the trapezoidal rule on the record times. A non-finite record makes
    W non-finite from there on."""
    n, m = traj.p_WB.shape[:2]
    power = np.zeros(n)
    if laws and n:
        q = np.asarray(traj.q_WB, float)
        with np.errstate(invalid="ignore"):
            R = rotation_from_quaternion((q / np.linalg.norm(q, axis=-1, keepdims=True)).reshape(-1, 4))
        R = R.reshape(n, m, 3, 3)
        V = np.asarray(traj.V_WB, float)
        for i in range(n):
            if not (np.all(np.isfinite(traj.p_WB[i])) and np.all(np.isfinite(V[i])) and np.all(np.isfinite(R[i]))):
                power[i:] = np.nan
                break
            power[i] = sum(p(float(traj.time[i]), traj.p_WB[i], R[i], V[i, :, 3:], V[i, :, :3]) for _, p in laws)
    dt = np.diff(np.asarray(traj.time, float))
    return np.concatenate([[0.0], np.cumsum(0.5 * dt * (power[1:] + power[:-1]))])
