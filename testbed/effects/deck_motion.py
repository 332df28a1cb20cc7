"""`deck_motion`: a ship's bay on a moving deck (roll, pitch, heave), with twistlocks.

The scene is simulated in the deck's frame D: the scene's quay/ground IS the deck, and the
plant's world frame is D. The deck's prescribed motion relative to the inertial world W
(testbed/effects/deck/motion.py: roll about D's x axis and pitch about its y axis through the
`pivot`, heave along W's z; harmonic or a time series; ramped in smoothly over `ramp_time`)
enters as the inertial (fictitious) forces and torques it causes on every free container
(testbed/effects/deck/law.py): the change of gravity's direction, the pivot's acceleration,
the Euler, centrifugal and Coriolis forces, and the rotating-frame terms of Euler's equation.
The plant's own gravity is kept; the law adds m (g_D - g), so the total is the gravity
rotated into the deck.

Why this design: every engine (Drake, MuJoCo, the learned hosts) already has a fixed ground;
the deck's motion becomes a body-force law that all of them apply alike (DeckMotionLaw), and
it is exact for rigid bodies: a body's motion in D under these wrenches is its motion in W
seen from the moving deck (tests/effects/test_deck_motion.py checks a free flight against
X_DW(t) applied to the analytic world-frame one).

Twistlocks. `open`: containers are held by friction alone (they slide once tan(roll) exceeds
mu, and a box tips once it exceeds w/h). `locked`: each free container's four bottom corner
castings are locked, at t = 0, to the container they sit on (its top face within 5 mm, the
corner inside its footprint) or to the deck: a stiff spring-damper in shear and in tension
only; contact still carries compression (so a learned contact model is still asked).
Stiffness 5e7 N/m per lock: a twistlock and its corner castings stretch a few mm at their
250 kN working load (ISO 1161 / class rules), i.e. 5e7 - 1e8 N/m. The springs and dampers are
explicit (computed from the state at each step's start): each of the locks' modes, stiffness
k S and damping c S over the mass matrix M (S: the unit lock stiffness, the same pattern for
both), is stable at the step h while h sqrt(k mu) < 2 and c h mu < 2, mu its generalized
eigenvalue S v = mu M v; `check` refuses a scene past 1 in either (a margin of 2) in any mode
(lock_mode_rates: the locks' graph at t = 0, the scene's mass properties). One body on its
four deck locks at (+-a, +-b) below its COM: translation mu = 4/m; yaw mu = 4 (a^2 + b^2) / I_zz
= 12/m for a uniform box (I_zz = m (a^2 + b^2) / 3), roll/pitch (rocking on the locks'
tension, coupled with sway by their shear at the lever h/2) 14.4/m for a 20 ft box. A stack of
n locked tiers multiplies these by its chain factor (1 on the deck, (3 + sqrt 5)/2 = 2.62 for
2 equal tiers, approaching 4): an empty 20 ft box (2200 kg) at 1 ms has h sqrt(k mu) = 0.30
(translation), 0.52 (yaw), 0.57 (roll/pitch) on the deck, yaw 0.85 two high, 0.98 four high
and 1.03 ten high (refused). Damping 4.5e4 N s/m per lock: c h mu = 12 c h / m x 4 = 0.98 for
the yaw mode of any stack of empty 20 ft boxes at 1 ms (the old 2e5 had 1.09 for one empty
box on the deck and 2.86 for two: Bullet diverged there without friction to absorb it;
ship_bay_large had 1.09); it leaves c / sqrt(k m) = 0.14 of critical for the translational
mode of an empty 20 ft box on its four locks (0.045 for a 20 t one).
Adds one system, `deck_loads`.
"""


import dataclasses
import math
import typing
from pathlib import Path

import numpy as np
import scipy.linalg
from pydrake.common.value import AbstractValue
from pydrake.multibody.math import SpatialForce
from pydrake.multibody.plant import ExternallyAppliedSpatialForce
from pydrake.systems.framework import LeafSystem

from testbed.effects import register
from testbed.effects.base import Effect, Role
from testbed.effects.deck.law import DeckMotionLaw, find_locks, mass_properties
from testbed.effects.deck.motion import DeckMotion, Harmonic, TimeSeries, load_series

TWISTLOCK_MODES = ("open", "locked")
DRAKE_GRAVITY = (0.0, 0.0, -9.81)  # [m/s^2] the plant's default gravity (the builder keeps it)


@dataclasses.dataclass
class DeckMotionConfig:
    roll: Harmonic = dataclasses.field(default_factory=lambda: Harmonic(0.0, 12.0, 0.0))  # [deg] about D's x
    pitch: Harmonic = dataclasses.field(default_factory=lambda: Harmonic(0.0, 8.0, 0.0))  # [deg] about D's y
    heave: Harmonic = dataclasses.field(default_factory=lambda: Harmonic(0.0, 10.0, 0.0))  # [m] along W's z
    # a CSV or .npz of t [s], roll [deg], pitch [deg], heave [m] replacing the harmonics ('' = none);
    # a relative path is taken from the scene file's folder
    time_series: str = ""
    pivot: typing.List[float] = dataclasses.field(default_factory=lambda: [0.0, 0.0, -6.0])  # p_DP [m]: the roll centre
    # [s] smooth (quintic) ramp of the motion from rest; short ramps are violent starts
    # (testbed/effects/deck/motion.py): the shipped bays start at the end of a roll instead
    ramp_time: float = 2.0
    twistlocks: str = "open"  # open | locked
    twistlock_stiffness: float = 5.0e7  # [N/m] per lock, shear and tension (module docstring)
    twistlock_damping: float = 4.5e4  # [N s/m] per lock (module docstring)


def deck_top(scenario) -> float | None:
    """z [m] of the deck's top face in D (the ground's), or None for a scene without ground."""
    if not scenario.ground:
        return None
    return 0.0 if scenario.ground_surface is None else float(scenario.ground_surface.height)


def build_law(config: DeckMotionConfig, scenario, free_specs, gravity=DRAKE_GRAVITY, series=None) -> DeckMotionLaw:
    """The DeckMotionLaw of a (checked) scene for its free containers `free_specs` (in the
    engine's body order); series: the loaded TimeSeries (None: load it from the config)."""
    if series is None and config.time_series:
        series = TimeSeries(*load_series(config.time_series, ValueError))
    motion = DeckMotion((config.roll, config.pitch, config.heave), config.pivot, config.ramp_time, series)
    masses, com, inertia = mass_properties(free_specs)
    locks = None
    if config.twistlocks == "locked":
        specs = list(scenario.containers)
        upper, lower, p_A, p_B = find_locks(specs, deck_top(scenario))
        index = {s.name: j for j, s in enumerate(free_specs)}
        to_free = np.array([index[specs[i].name] for i in upper], int)
        lower_free = np.array([-1 if i < 0 else index[specs[i].name] for i in lower], int)
        locks = (to_free, lower_free, p_A, p_B)
    return DeckMotionLaw(motion, gravity, masses, com, inertia, locks,
                         config.twistlock_stiffness, config.twistlock_damping)


# Degrees of freedom (per free body: COM translation x y z, rotation x y z, in D) of the locks'
# modes that _check_lock_stability checks, the largest of each; "coupled": all of them at once.
LOCK_MODES = {"translation": (0, 1, 2), "yaw": (5,), "roll/pitch": (0, 1, 3, 4), "coupled": tuple(range(6))}


def lock_mode_rates(scenario) -> dict:
    """{mode: mu [1/kg, 1/(kg m^2)]} of LOCK_MODES: the largest generalized eigenvalue of the
    locks' unit stiffness S (k = 1 N/m) against the free bodies' mass matrix M (mass_properties),
    linearized at the t = 0 poses, over the mode's degrees of freedom, over every group of
    bodies the locks join (a stack); the mode's stiffness and damping are k S and c S, so its
    explicit figures are h sqrt(k mu) and c h mu. Every lock counts in shear and in tension
    (an upper bound: a tension-only lock adds less). {} without locks."""
    specs = list(scenario.containers)
    upper, lower, p_A, _ = find_locks(specs, deck_top(scenario))
    if not upper.size:
        return {}
    group = {j: j for j in set(upper.tolist())}  # union-find over the locks' free bodies

    def root(j):
        while group[j] != j:
            j = group[j]
        return j

    for a, b in zip(upper.tolist(), lower.tolist()):
        if b >= 0:
            group[root(a)] = root(b)
    rates = dict.fromkeys(LOCK_MODES, 0.0)
    for r in set(root(j) for j in group):
        bodies = sorted(j for j in group if root(j) == r)
        for mode, mu in _group_rates(specs, bodies, [(a, b, p) for a, b, p in zip(upper, lower, p_A) if a in bodies]).items():
            rates[mode] = max(rates[mode], mu)
    return rates


def _group_rates(specs, bodies, locks) -> dict:
    """lock_mode_rates of one group of free bodies (indices into specs) and its locks (upper,
    lower index or -1, corner in the upper body's frame C)."""
    index = {j: i for i, j in enumerate(bodies)}
    masses, com, inertia = mass_properties([specs[j] for j in bodies])
    poses = [specs[j].pose() for j in bodies]
    R = np.array([X.rotation().matrix() for X in poses]).reshape(-1, 3, 3)
    com_D = np.array([X.translation() for X in poses]).reshape(-1, 3) + np.einsum("kij,kj->ki", R, com)
    n = len(bodies)
    M, S = np.zeros((6 * n, 6 * n)), np.zeros((6 * n, 6 * n))
    for i in range(n):
        M[6 * i:6 * i + 3, 6 * i:6 * i + 3] = masses[i] * np.eye(3)
        M[6 * i + 3:6 * i + 6, 6 * i + 3:6 * i + 6] = R[i] @ inertia[i] @ R[i].T
    for a, b, corner in locks:
        A = index[a]
        q = com_D[A] + R[A] @ (corner - com[A])  # the corner, in D
        J = np.zeros((3, 6 * n))  # the gap's rate from the bodies' COM and angular velocities
        for body, sign in ((A, 1.0), (index.get(int(b)), -1.0)):
            if body is not None:  # None: the deck or a fixed body
                x, y, z = q - com_D[body]
                J[:, 6 * body:6 * body + 3] += sign * np.eye(3)
                J[:, 6 * body + 3:6 * body + 6] -= sign * np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])
        S += J.T @ J
    rates = {}
    for mode, dofs in LOCK_MODES.items():
        keep = (6 * np.arange(n)[:, None] + np.array(dofs)).ravel()
        rates[mode] = float(scipy.linalg.eigh(S[np.ix_(keep, keep)], M[np.ix_(keep, keep)], eigvals_only=True)[-1])
    return rates


class DeckLoads(LeafSystem):
    """Applies DeckMotionLaw's wrenches (at each free body's COM) through the plant's applied-force port."""

    def __init__(self, assembly, config: DeckMotionConfig, series=None):
        super().__init__()
        self.set_name("deck_loads")
        plant = assembly.plant
        specs = [c for c in assembly.scenario.containers if not c.fixed]
        self._bodies = [assembly.bodies[c.name] for c in specs]
        self._index = np.array([int(b.index()) for b in self._bodies], int)
        gravity = plant.gravity_field().gravity_vector()
        self.law = build_law(config, assembly.scenario, specs, gravity, series)
        self._poses = self.DeclareAbstractInputPort("body_poses", plant.get_body_poses_output_port().Allocate())
        self._velocities = self.DeclareAbstractInputPort(
            "body_spatial_velocities", plant.get_body_spatial_velocities_output_port().Allocate())
        self.DeclareAbstractOutputPort(
            "spatial_forces", lambda: AbstractValue.Make([ExternallyAppliedSpatialForce()]), self._calc)
        assembly.builder.AddSystem(self)
        assembly.builder.Connect(plant.get_body_poses_output_port(), self._poses)
        assembly.builder.Connect(plant.get_body_spatial_velocities_output_port(), self._velocities)
        assembly.add_spatial_forces(self.get_output_port())

    def _calc(self, context, output) -> None:
        poses, velocities = self._poses.Eval(context), self._velocities.Eval(context)
        X = [poses[i] for i in self._index]
        V = [velocities[i] for i in self._index]
        p = np.array([x.translation() for x in X]).reshape(-1, 3)
        R = np.array([x.rotation().matrix() for x in X]).reshape(-1, 3, 3)
        v = np.array([s.translational() for s in V]).reshape(-1, 3)
        w = np.array([s.rotational() for s in V]).reshape(-1, 3)
        rows = self.law.wrenches_D(context.get_time(), p, R, v, w)
        forces = []
        for body, com, row in zip(self._bodies, self.law.com_C, rows):
            f = ExternallyAppliedSpatialForce()
            f.body_index = body.index()
            f.p_BoBq_B = com  # the COM, in the body frame C
            f.F_Bq_W = SpatialForce(tau=row[3:], f=row[:3])
            forces.append(f)
        output.set_value(forces)


@register
class DeckMotionEffect(Effect):
    name = "deck_motion"
    Config = DeckMotionConfig
    role = Role.PHYSICS
    translated_by = ("mujoco", "bullet")
    order = 21
    measured_alone = False  # the default config keeps the deck at rest: nothing to measure

    def check(self, effects) -> None:
        super().check(effects)
        c = self.config
        for axis in ("roll", "pitch", "heave"):
            h = getattr(c, axis)
            for field in ("amplitude", "period", "phase_deg"):
                value = getattr(h, field)
                if not (isinstance(value, (int, float)) and math.isfinite(value)):
                    raise self.fail(f"{axis}.{field}", f"expected a finite number, got {value}")
            if not h.period > 0:
                raise self.fail(f"{axis}.period", f"expected a positive period [s], got {h.period}")
        for axis, limit in (("roll", 60.0), ("pitch", 30.0)):
            if abs(getattr(c, axis).amplitude) > limit:
                raise self.fail(f"{axis}.amplitude", f"expected at most {limit:g} deg, got {getattr(c, axis).amplitude}")
        if len(c.pivot) != 3 or not all(math.isfinite(v) for v in c.pivot):
            raise self.fail("pivot", f"expected 3 finite numbers p_DP [m], got {c.pivot}")
        if not (math.isfinite(c.ramp_time) and c.ramp_time >= 0):
            raise self.fail("ramp_time", f"expected a finite non-negative time [s], got {c.ramp_time}")
        if c.twistlocks not in TWISTLOCK_MODES:
            raise self.fail("twistlocks", f"unknown {c.twistlocks!r}; expected one of: {', '.join(TWISTLOCK_MODES)}")
        for field in ("twistlock_stiffness", "twistlock_damping"):
            value = getattr(c, field)
            if not (math.isfinite(value) and value >= 0):
                raise self.fail(field, f"expected a finite non-negative number, got {value}")
        self.series = self._load_series() if c.time_series else None
        if c.twistlocks == "locked":
            self._check_lock_stability()

    def _load_series(self) -> TimeSeries:
        path = Path(self.config.time_series)
        if not path.is_absolute() and str(self.source) not in ("<scenario>", "<string>"):
            path = Path(str(self.source).split(" (with --set")[0]).resolve().parent / path

        def error(problem):
            return self.fail("time_series", f"{path}: {problem}")

        if not path.exists():
            raise error("no such file; expected a CSV or .npz of t [s], roll [deg], pitch [deg], heave [m]")
        t, q = load_series(path, error)
        self.config.time_series = str(path.resolve())  # engines that rebuild the law read it from here
        duration = self.scenario.duration
        if t[0] > 0 or t[-1] < duration:
            raise error(f"t covers [{t[0]:g}, {t[-1]:g}] s; expected it to cover the scene's [0, {duration:g}] s")
        return TimeSeries(t, q)

    def _check_lock_stability(self) -> None:
        """Refuses locks too stiff or too damped for the explicit step, mode by mode (LOCK_MODES,
        lock_mode_rates): h sqrt(k mu) <= 1 and c h mu <= 1 (margins of 2 on the limits 2, 2)."""
        h, c = self.scenario.plant.time_step, self.config
        rates = lock_mode_rates(self.scenario)
        if not rates:
            return
        mu = rates["coupled"]  # the largest: all the degrees of freedom at once
        mode = max((m for m in rates if m != "coupled"), key=rates.get)
        mode = mode if rates[mode] >= mu * (1 - 1e-9) else "coupled"
        if h * math.sqrt(c.twistlock_stiffness * mu) > 1:
            raise self.fail("twistlock_stiffness", f"{c.twistlock_stiffness:g} N/m is too stiff for the {h:g} s step: "
                                                   f"the locks' {mode} mode has h sqrt(k mu) = "
                                                   f"{h * math.sqrt(c.twistlock_stiffness * mu):.3g} > 1; "
                                                   f"expected at most {1 / (h * h * mu):.3g} N/m")
        if c.twistlock_damping * h * mu > 1:
            raise self.fail("twistlock_damping", f"{c.twistlock_damping:g} N s/m is too high for the {h:g} s step: "
                                                 f"the locks' {mode} mode has c h mu = {c.twistlock_damping * h * mu:.3g} "
                                                 f"> 1; expected at most {1 / (h * mu):.3g} N s/m")

    def external_power(self):
        """The deck's power [W] on the scene's free containers (DeckMotionLaw.power_W: its
        inertial wrenches and the twistlocks) as a function of a record (t [s], p_DB (m, 3) [m],
        R_DB (m, 3, 3), v_DB (m, 3) [m/s] body-origin velocities, w_DB (m, 3) [rad/s], free
        containers in scene order, all in the deck frame D: the plant's world)."""
        specs = [c for c in self.scenario.containers if not c.fixed]
        law = build_law(self.config, self.scenario, specs, DRAKE_GRAVITY, getattr(self, "series", None))
        return law.power_W

    def add_systems(self, assembly) -> list:
        return [DeckLoads(assembly, self.config, getattr(self, "series", None))]

    def summarize(self, tables) -> dict:
        c = self.config
        locks = self.systems[0].law.upper.size if self.systems else 0
        return {"deck_roll_amplitude_deg": c.roll.amplitude, "deck_twistlocks": locks}
