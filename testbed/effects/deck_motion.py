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
250 kN working load (ISO 1161 / class rules), i.e. 5e7 - 1e8 N/m; the lower end of that range
keeps the explicit spring (computed from the state at each step's start) well inside its
stability limit h sqrt(4 k / m) < 2 at 1 ms for an empty 20 ft box (0.43 at 2200 kg; `check`
refuses a scene whose lightest locked body exceeds 1). Damping 2e5 N s/m per lock: about 0.2
of critical for an empty 20 ft box on four locks (explicit limit 4 c h / m < 2: 0.36).
Adds one system, `deck_loads`.
"""


import dataclasses
import math
import typing
from pathlib import Path

import numpy as np
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
    twistlock_damping: float = 2.0e5  # [N s/m] per lock


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
        """Refuses locks too stiff or too damped for the explicit step: h sqrt(4 k / m) <= 1
        and 4 c h / m <= 1 for the lightest free container (margins of 2 on the limits 2, 2)."""
        free = [s for s in self.scenario.containers if not s.fixed]
        if not free:
            return
        m = min(s.total_mass() for s in free)
        h, c = self.scenario.plant.time_step, self.config
        if h * math.sqrt(4 * c.twistlock_stiffness / m) > 1:
            raise self.fail("twistlock_stiffness", f"{c.twistlock_stiffness:g} N/m is too stiff for the {h:g} s step with "
                                                   f"a {m:g} kg container; expected at most {m / (4 * h * h):.3g} N/m")
        if 4 * c.twistlock_damping * h / m > 1:
            raise self.fail("twistlock_damping", f"{c.twistlock_damping:g} N s/m is too high for the {h:g} s step with "
                                                 f"a {m:g} kg container; expected at most {m / (4 * h):.3g} N s/m")

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
