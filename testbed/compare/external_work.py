"""The work external actors do on a run's free containers, integrated over its records.

An external actor is a PHYSICS effect that pushes the containers from outside the contact
model: the wind (testbed/effects/wind.py), a crane's ropes (crane.py), the moving deck and its
twistlocks (deck_motion.py). Each says so with an `external_power()` method returning its power
[W] as a pure function of one record (t, p_WB, R_WB, v_WB, w_WB: the free containers' poses and
body-origin velocities in the plant's world, scene order), built from the very law object the
simulation applies (no second copy of a formula). A law that stops during a run (a crane's
ropes, whose twistlocks release on seating or on schedule) says when through `until(events)` [s]:
from the run's Trajectory.events (what the run decided that its states do not hold: the crane's
crane_release_time_s, recorded by every engine), None where they do not say (the work is then
not known and the gate keeps its rule before the work was counted).

W(t) [J] is the trapezoidal integral of the summed power over the record times, each law's power
linear between records and cut at its `until` (a record period straddling it: to the power
interpolated there). The energy the contact model (contact and friction) put in is then
C(t) = E(t) - E(0) - W(t): <= 0 for passive contact, up to the integration error of sampling the
power at the record period (the compare path records every 10 ms, ten 1 ms plant steps;
tests/closed_loop/test_external_work.py measures that error and the closed-loop gate,
testbed/gates/closed_loop.py, reads C). A landing load's ropes unload within one record period:
there the sampling errs most (a 20 t box landing at 1 m/s: 0.66 kJ of W's 52 kJ at 10 ms).

Why here, where the records are written (artifacts.write_series), rather than in the gate: the
records hold the state but not the scene that ran (its `--set` overrides, a derived variant),
and the gates are keyed by a scene's name alone; the writer has the very Scenario of the run.
"""

from __future__ import annotations

import math

import numpy as np

from testbed.gates.closed_loop import energy_created
from testbed.geometry.rotations import rotation_from_quaternion
from testbed.scenario import checked_effects


def power_laws(scenario) -> list | None:
    """[(effect name, power(t, p, R, v, w) -> W)] of `scenario`'s external actors ([]: none),
    or None when one of them cannot be evaluated from records (an effect whose external_power()
    is None)."""
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


def until(law, events: dict) -> float | None:
    """[s] when `law` stops working in a run with Trajectory.events `events`: its until(events)
    (None: not known), inf for a law that never stops."""
    stop = getattr(law, "until", None)
    return math.inf if stop is None else stop(events)


def external_work(laws, traj) -> np.ndarray | None:
    """(n,) [J] the work W(t) of `laws` (power_laws) on the run `traj` (a Trajectory: time
    (n,) [s], p_WB (n, m, 3), q_WB (n, m, 4) w x y z, V_WB (n, m, 6) [angular, linear], events)
    from its first record to each: the trapezoidal rule on the record times, each law cut at its
    `until`. None when a law's stop is not known from `traj.events` (a crane's release on seating
    that the run did not record) and there is more than one record. A non-finite record makes W
    non-finite from there on."""
    stops = [until(law, getattr(traj, "events", {})) for _, law in laws]
    if any(s is None for s in stops):
        if len(traj.time) > 1:
            return None
        stops = [math.inf] * len(laws)  # one record (a run refused at its start): W = 0 whenever they stop
    n, m = traj.p_WB.shape[:2]
    time = np.asarray(traj.time, float)
    work = np.zeros(n)
    if not (laws and n > 1):
        return work
    q = np.asarray(traj.q_WB, float)
    with np.errstate(invalid="ignore"):
        R = rotation_from_quaternion((q / np.linalg.norm(q, axis=-1, keepdims=True)).reshape(-1, 4))
    R = R.reshape(n, m, 3, 3)
    V = np.asarray(traj.V_WB, float)
    finite = np.array([np.all(np.isfinite(traj.p_WB[i])) and np.all(np.isfinite(V[i])) and np.all(np.isfinite(R[i]))
                       for i in range(n)])
    bad = int(np.argmin(finite)) if not finite.all() else n  # the first non-finite record
    for (_, law), stop in zip(laws, stops):
        power = np.zeros(n)
        last = min(bad, int(np.searchsorted(time, stop)) + 1)  # the records up to the first at or past the stop
        for i in range(last):
            power[i] = law(float(time[i]), traj.p_WB[i], R[i], V[i, :, 3:], V[i, :, :3])
        work += cut_trapezoid(time, power, stop)
    work[bad:] = np.nan
    return work


def energy_figures(laws, truth, traj, truth_work=None) -> dict:
    """compare.json's energy figures of the run `traj` against `truth` (Trajectories on the same
    record times), with the external actors' `laws` (power_laws; None: not evaluable) and the
    truth's work `truth_work` (external_work(laws, truth), computed once for every candidate):
    energy_created_J, the energy gate's figure (testbed.gates.closed_loop.energy_created: the
    largest C(t) = E(t) - E(0) - W(t) beyond the truth's C(t) where positive), whatever engine ran;
    external_work_counted (whether W came from the records); external_work_max_J [J], the largest
    |W(t)| of the run (0 without an actor; None where not counted). The raw E(t) - E(0) beside it
    is compare_figures' energy_gain_max_J."""
    n = len(traj.time)
    work = None if laws is None or truth_work is None else external_work(laws, traj)
    pair = None if work is None else (work, truth_work[:n])
    largest = None if work is None else float(np.max(np.abs(np.nan_to_num(work, nan=np.inf)), initial=0.0))
    return {"energy_created_J": energy_created(traj.energy, np.asarray(truth.energy)[:n], pair),
            "external_work_counted": pair is not None, "external_work_max_J": largest}


def cut_trapezoid(time, power, stop: float) -> np.ndarray:
    """(n,) the integral of the piecewise-linear `power` (n,) over `time` (n,) from time[0] to each
    record, of its part before `stop` alone (a record period straddling it: to the power
    interpolated at stop)."""
    t0, t1 = time[:-1], time[1:]
    end = np.clip(stop, t0, t1)
    with np.errstate(invalid="ignore", divide="ignore"):
        frac = np.where(t1 > t0, (end - t0) / (t1 - t0), 0.0)
    at_end = power[:-1] + frac * (power[1:] - power[:-1])
    return np.concatenate([[0.0], np.cumsum(0.5 * (end - t0) * (power[:-1] + at_end))])
