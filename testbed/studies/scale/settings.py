"""The scale study's settings: its models (read from the engine registry) and ScaleConfig.

Models: every registered engine (testbed.engines.engines()) gives the study its models, so a
new engine appears in the study with no edit here:

- Drake (the reference engine): one model per contact model of testbed/effects/contact.py
  outside the hydroelastic family ('point', ...) and 'hydroelastic' (the yard's own
  hydroelastic_with_fallback: the reference every model is judged against);
- an engine whose contact a learned predictor decides (gated or learned: 'learned', Drake
  hosting the loop; 'mujoco_learned', MuJoCo hosting it): one model, run with the config's
  predictor;
- any other engine ('mujoco', 'bullet', ...): one model at its first contact-parameter set
  (MuJoCo's 'matched' to Drake's hydroelastic contact).
"""

from __future__ import annotations

import dataclasses
import math
import typing

from testbed.bodies.containers import CONTAINER_TYPES
from testbed.bodies.yards import MAX_TIERS, MAX_YARD_CONTAINERS
from testbed.effects.contact import CONTACT_MODELS
from testbed.engines import engines
from testbed.engines.candidate import Candidate
from testbed.errors import TestbedError

REFERENCE = "hydroelastic"  # the model every other is judged against: Drake, the yard's own contact model
YARD_CONTACT = "hydroelastic_with_fallback"  # the yards' contact model (Drake's reference runs)
CONTINUED = ("mujoco_learned",)  # the engines whose timed window continues the settling run (window.py)
YARDS = ("settled", "crane")  # the yard kinds: nothing happens / one crane landing a load on a stack
# the cost per step the fits and targets read: the process's CPU time (robust on a shared machine) or the wall time
CLOCKS = {"cpu": ("cpu_us_per_step", "cpu_real_time_factor"), "wall": ("us_per_step", "real_time_factor")}
# the labels of the shipped engines' models as the reports have always printed them (others: the engine's label)
KNOWN_LABELS = {"hydroelastic": "Drake hydroelastic", "point": "Drake point", "learned": "learned loop (in Drake)",
                "mujoco": "MuJoCo (matched)", "mujoco_learned": "learned loop (in MuJoCo)"}


def models() -> dict[str, Candidate]:
    """Model name -> its Candidate (testbed/engines/candidate.py: engine, contact parameters,
    label; a learned one (`judged`) runs with the config's predictor), in engine registry order
    (see the module doc)."""
    out = {}
    for name, engine in engines().items():
        if engine.reference:
            out[REFERENCE] = Candidate(name, None, label=KNOWN_LABELS[REFERENCE])
            for contact in CONTACT_MODELS:
                if not contact.startswith("hydroelastic"):
                    out[contact] = Candidate(name, contact, label=KNOWN_LABELS.get(contact, f"{engine.label} {contact}"))
        elif engine.gated or engine.learned:
            out[name] = Candidate(name, label=KNOWN_LABELS.get(name, f"{engine.label} (learned)"))
        else:
            params = engine.param_sets[0] if engine.param_sets else None
            out[name] = Candidate(name, params, label=KNOWN_LABELS.get(name, engine.label + (f" ({params})" if params else "")))
    return out


def label(model: str) -> str:
    """The model's label as printed (the name itself for a model no engine gives any more)."""
    spec = models().get(model)
    return spec.label if spec else model


class ScaleConfigError(TestbedError):
    """A scale study setting that cannot run (one line: the option and what it expects)."""


@dataclasses.dataclass(frozen=True)
class ScaleConfig:
    """The study's grid, its yards and its timing windows.

    sizes: containers per yard, each a multiple of `tiers` (N = rows x bays x tiers, the stacks
    laid out as square as N allows, rows <= bays); the yard's container type, gaps [m] and
    masses [kg] (drawn uniformly per container with `seed`, heaviest at the bottom of each
    stack) as testbed/bodies/yards.py. Every run first SETTLES, untimed, from rest; the timed
    window then lasts duration [s] up to `big_above` containers, big_duration [s] above.
    The MuJoCo-hosted learned loop (CONTINUED) settles settle_s [s] (0.8) and its window
    CONTINUES that run (window.py): the learned step's sleeping islands (asleep after t_sleep =
    0.3 s below v_sleep = 1e-3 m/s) are asleep when the window starts. Measured on the 1AA
    yards: every stack is below v_sleep by about 0.4 s, asleep islands hold 29 % of the
    96-yard and 17 % of the 1000-yard at 0.6 s, 98 % of the 1000-yard at 0.7 s, and all of both
    from 0.75 s; each row reports the asleep fraction at its window's start
    (start_asleep_fraction). A fresh run from a settled state would restart every island's
    rest timer (a 0.1 s window never sleeps). Every other model settles min(settle_s,
    fresh_settle_s) [s] (0.1) and its window is a fresh run from that settled state (every
    container's pose and velocity at the end of the settling run of the same engine and model):
    Drake's and MuJoCo's own steps hold no sleep state, but the Drake-hosted learned loop's
    islands restart there (awake in its window), and its cost per step (capped at N = 192) would
    make a 0.8 s settle cost minutes a cell. time_step [s] of every
    engine. models: keys of models() (None: all); yards: some of YARDS; caps: model -> the
    largest N it runs (above: the cell is 'skipped', said in the report); predictor: of the
    learned loops (None: each engine's default). The crane yard adds one load (crane_type,
    crane_mass [kg]) hanging at rest crane_gap [m] above the middle stack, lowered at
    crane_speed [m/s] and crane_acceleration [m/s^2] from the window's start: it lands
    inside the window and settles on the stack (in a continued run the load hangs still
    through the settling, crane_gap above the stack's top from rest, which sags about 1 mm
    meanwhile: start_load_clearance_m; the rest of the yard may be asleep). clock: the cost per step the fits and targets
    read (CLOCKS: 'wall', the window's stepping, or 'cpu', this process's CPU time over the window
    run less that of a second build and one step, which other work on a shared machine hardly
    disturbs but the build's own spread does). fit_from: smallest N of the growth fits;
    passes: the whole grid is measured this many times, one growth fit per pass; repeats:
    a timed window shorter than repeat_below_s [s of wall] is repeated up to this many
    times and the fastest kept (the runs are deterministic; a short one is the most
    disturbed by other work on a shared machine)."""

    sizes: tuple[int, ...] = (96, 192, 480, 1000)
    tiers: int = 4
    container_type: str = "1AA"
    row_gap: float = 0.4  # [m]
    bay_gap: float = 0.6  # [m]
    mass_range: tuple[float, float] = (8000.0, 28000.0)  # [kg]
    seed: int = 29
    settle_s: float = 0.8  # [s] untimed, from rest, then the window continues the run (CONTINUED)
    fresh_settle_s: float = 0.1  # [s] untimed, from rest, of the other models (at most settle_s): then a fresh window
    duration: float = 0.1  # [s] timed window
    big_duration: float = 0.06  # [s] timed window above big_above
    big_above: int = 192  # containers
    time_step: float = 1e-3  # [s]
    models: typing.Optional[tuple[str, ...]] = None
    yards: tuple[str, ...] = YARDS
    # the largest N of the Drake-hosted models: past the settling their cost per step grows ~N^2.5 (0.5 s per
    # step for point contact at N = 192 on the shared 2-core machine): a 480-yard would take ~15 min a pass
    caps: tuple[tuple[str, int], ...] = (("hydroelastic", 96), ("point", 192), ("learned", 192))
    predictor: str | None = None
    crane_type: str = "1AA"
    crane_mass: float = 25000.0  # [kg]
    crane_gap: float = 0.002  # [m]
    crane_speed: float = 0.2  # [m/s]
    crane_acceleration: float = 4.0  # [m/s^2]
    # the cost the fits and targets read: "wall" (the window's stepping) or "cpu" (this process's CPU time less a
    # second build's and one step's: noisy where a build costs about as much as the window, e.g. N = 1000)
    clock: str = "wall"
    fit_from: int = 96
    passes: int = 2
    repeats: int = 3
    repeat_below_s: float = 1.0  # [s]

    def model_names(self) -> tuple[str, ...]:
        """The models run, in config order (None: every model, in registry order)."""
        return tuple(self.models) if self.models is not None else tuple(models())

    def continues(self, model: str) -> bool:
        """Whether `model`'s window continues its settling run (window.py) rather than starting
        a fresh run from the settled state."""
        spec = models().get(model)
        return spec is not None and spec.engine in CONTINUED

    def settle_for(self, model: str) -> float:
        """[s] untimed from rest before `model`'s window: settle_s where the window continues
        the run, else min(settle_s, fresh_settle_s)."""
        return self.settle_s if self.continues(model) else min(self.settle_s, self.fresh_settle_s)

    def duration_for(self, n: int) -> float:
        """[s] of the timed window in the runs of the N-container yard."""
        return self.big_duration if n > self.big_above else self.duration

    def cap(self, model: str) -> int | None:
        """The largest N `model` runs (None: no cap)."""
        return dict(self.caps).get(model)

    def landing_s(self) -> float:
        """[s] after the window's start when the load would touch the stack, were it to follow
        the hoist exactly (a trapezoidal descent over crane_gap)."""
        reach = self.crane_speed**2 / (2 * self.crane_acceleration)  # [m] descent while accelerating
        if self.crane_gap <= reach:
            return math.sqrt(2 * self.crane_gap / self.crane_acceleration)
        return self.crane_speed / self.crane_acceleration + (self.crane_gap - reach) / self.crane_speed

    def validate(self) -> None:
        """Raises ScaleConfigError naming the setting for anything that cannot run."""
        if not self.sizes:
            raise ScaleConfigError("--sizes: expected at least one yard size")
        if not 1 <= self.tiers <= MAX_TIERS - 1:  # a tier above the stacks for the crane's load
            raise ScaleConfigError(f"--tiers: expected 1 to {MAX_TIERS - 1} tiers, got {self.tiers}")
        bad = [n for n in self.sizes if not (isinstance(n, int) and n >= self.tiers and n % self.tiers == 0)]
        if bad:
            raise ScaleConfigError(f"--sizes: expected multiples of the {self.tiers} tiers (N = rows x bays x tiers), got {bad}")
        if max(self.sizes) > MAX_YARD_CONTAINERS:
            raise ScaleConfigError(f"--sizes: at most {MAX_YARD_CONTAINERS} containers per yard, got {max(self.sizes)}")
        if len(set(self.sizes)) != len(self.sizes):
            raise ScaleConfigError(f"--sizes: a size is listed twice in {list(self.sizes)}")
        known = models()
        unknown = [m for m in self.model_names() if m not in known]
        if unknown or not self.model_names():
            raise ScaleConfigError(f"--models: unknown {unknown}; expected some of: {', '.join(known)}")
        if not self.yards or any(y not in YARDS for y in self.yards) or len(set(self.yards)) != len(self.yards):
            raise ScaleConfigError(f"--yards: expected some of {', '.join(YARDS)}, got {list(self.yards)}")
        bad_caps = [(m, n) for m, n in self.caps if m not in known or not (isinstance(n, int) and n >= 1)]
        if bad_caps:
            raise ScaleConfigError(f"--caps: expected MODEL=N with a known model and N >= 1, got {bad_caps}")
        for name in ("settle_s", "fresh_settle_s", "duration", "big_duration", "time_step"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                option = {"settle_s": "settle", "fresh_settle_s": "fresh-settle"}.get(name, name).replace("_", "-")
                raise ScaleConfigError(f"--{option}: expected a positive number of seconds, got {value}")
        if self.time_step > min(self.settle_s, self.duration, self.big_duration):
            raise ScaleConfigError(f"--time-step: {self.time_step:g} s is longer than a run "
                                   f"({min(self.settle_s, self.duration, self.big_duration):g} s)")
        for name in ("container_type", "crane_type"):
            if getattr(self, name) not in CONTAINER_TYPES:
                raise ScaleConfigError(f"{name.replace('_', ' ')}: unknown {getattr(self, name)!r}; "
                                       f"expected one of: {', '.join(CONTAINER_TYPES)}")
        for name in ("crane_mass", "crane_gap", "crane_speed", "crane_acceleration"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ScaleConfigError(f"{name.replace('_', ' ')}: expected a positive number, got {value}")
        if self.clock not in CLOCKS:
            raise ScaleConfigError(f"--clock: expected one of {', '.join(CLOCKS)}, got {self.clock!r}")
        if self.repeats < 1:
            raise ScaleConfigError(f"--repeats: expected at least 1, got {self.repeats}")
        if self.passes < 1:
            raise ScaleConfigError(f"--passes: expected at least 1, got {self.passes}")


QUICK = ScaleConfig(sizes=(4, 8, 16), settle_s=0.02, duration=0.04, big_duration=0.04, big_above=16, caps=(),
                    fit_from=4, passes=1, repeats=1)


def from_dict(raw: dict) -> ScaleConfig:
    """A ScaleConfig from dataclasses.asdict (lists back to tuples, as after a JSON or Ray trip)."""
    fields = {f.name for f in dataclasses.fields(ScaleConfig)}

    def tup(v):
        return tuple(tup(x) for x in v) if isinstance(v, (list, tuple)) else v

    return ScaleConfig(**{k: tup(v) for k, v in raw.items() if k in fields})
