"""The one home of "the same scene, but ...": composable edits of a loaded Scenario.

`derive(scenario, *edits)` deep-copies the scenario once and applies each edit to the copy
in the order given; the caller's scenario is never changed. An edit is a callable
`(copy) -> None`; the ones here are the variants the commands, studies and engines use:

  physics_only(learned)        every effect whose Role is not PHYSICS off (recorders,
                               observers, viewers): the dynamics alone, for timing;
                               learned=False: the learned loop off too (Drake's own contact)
  keep_effects(names)          only the named effects (the bare scene of a cost study)
  recorders(on)                every RECORDER effect on with its study_config (on) or off
  effects_on(names)            the named effects on with their study_config (a cost study)
  log_contacts(every)          the contact_log recorder on, every `every` steps (None: one
                               RECORD_PERIOD in whole steps; keep=True: a declared one stays)
  contact(model, approximation)  the contact model (and approximation) in effects.contact,
                               the plant's copies derived again (scenario.derive_plant)
  modulus(value)               effects.contact.hydroelastic_modulus [Pa]; None: the learned
                               law's (learned_dynamics.force_law.law_modulus of the scene)
  contact_params(...)          the other contact settings: hydroelastic margin [m], modulus [Pa]
                               and the plant's stiction tolerance [m/s], as given
  learned_loop(predictor)      the learned closed loop (learned_dynamics) on: the scene's own
                               config if it declares one, else the defaults; `predictor`
                               replaces its predictor; shadow_truth off
  timing(time_step, duration)  plant.time_step [s] and/or duration [s]

Example: the twin run's point-contact Drake run is
`derive(s, modulus(None), physics_only(learned=False), contact("point"))`.
"""

from __future__ import annotations

import copy
import dataclasses

from testbed.effects import Role, registry
from testbed.effects.contact_log import ContactLogConfig
from testbed.effects.learned_dynamics.effect import LearnedDynamicsConfig
from testbed.effects.learned_dynamics.force_law import law_modulus
from testbed.records import steps_per_record
from testbed.scenario import derive_plant

KEEP = object()  # contact_params: leave this setting as it is

def derive(scenario, *edits):
    """A deep copy of `scenario` with `edits` applied in order (see the module doc)."""
    out = copy.deepcopy(scenario)
    for edit in edits:
        edit(out)
    return out


def physics_only(learned: bool = True):
    """Every effect whose role is not PHYSICS off; `learned` False: learned_dynamics (the
    learned closed loop, a PHYSICS effect) off as well."""
    def edit(s):
        for name, cls in registry().items():
            if (cls.role is not Role.PHYSICS or (not learned and name == "learned_dynamics")) and hasattr(s.effects, name):
                setattr(s.effects, name, None)
    return edit


def keep_effects(names):
    """Only the effects in `names` (as the scene declares them); every other one off."""
    keep = set(names)

    def edit(s):
        for name in registry():
            if name not in keep and hasattr(s.effects, name):
                setattr(s.effects, name, None)
    return edit


def recorders(on: bool = True):
    """Every RECORDER effect (Drake's own contact: the ground truth) on with its
    study_config (`on`) or off."""
    def edit(s):
        for name, cls in registry().items():
            if cls.role is Role.RECORDER:
                setattr(s.effects, name, cls.study_config() if on else None)
    return edit


def effects_on(names):
    """The effects in `names` on, each with its study_config (its defaults; a viewer never
    on a fixed port)."""
    def edit(s):
        for name in names:
            setattr(s.effects, name, registry()[name].study_config())
    return edit


def log_contacts(every: int | None = 1, *, keep: bool = False):
    """contact_log on, every `every` plant steps (None: records.RECORD_PERIOD in whole steps
    of the copy's time step, applied after any timing edit before it); keep: a contact_log
    the scene declares stays as it is."""
    def edit(s):
        if keep and s.effects.contact_log is not None:
            return
        s.effects.contact_log = ContactLogConfig(every_steps=every or steps_per_record(s.plant.time_step))
    return edit


def contact_params(*, margin=KEEP, modulus=KEEP, stiction_tolerance=KEEP):
    """effects.contact.hydroelastic_margin [m] and hydroelastic_modulus [Pa] (None: the
    SDF's) and plant.stiction_tolerance [m/s]; a setting left out stays as it is."""
    def edit(s):
        if margin is not KEEP:
            s.effects.contact = dataclasses.replace(s.effects.contact, hydroelastic_margin=margin)
        if modulus is not KEEP:
            s.effects.contact = dataclasses.replace(s.effects.contact, hydroelastic_modulus=modulus)
        if stiction_tolerance is not KEEP:
            s.plant.stiction_tolerance = stiction_tolerance
    return edit


def contact(model: str | None = None, approximation: str | None = None):
    """Contact `model` and/or `approximation` (Drake's names, or "auto") in effects.contact;
    the plant's copies of both are derived again from it (scenario.derive_plant)."""
    def edit(s):
        if model is not None:
            s.effects.contact = dataclasses.replace(s.effects.contact, model=model)
        if approximation is not None:
            s.effects.contact = dataclasses.replace(s.effects.contact, approximation=approximation)
        derive_plant(s)
    return edit


def modulus(value: float | None = None):
    """effects.contact.hydroelastic_modulus = `value` [Pa]; None: the learned law's modulus
    (the scene's own when it sets one, else learned_dynamics.force_law.KAPPA_MODULUS). No contact
    effect: nothing to set."""
    def edit(s):
        if s.effects.contact is not None:
            given = law_modulus(s) if value is None else value
            s.effects.contact = dataclasses.replace(s.effects.contact, hydroelastic_modulus=given)
    return edit


def learned_loop(predictor: str | None = None, given=None):
    """learned_dynamics on: `given` (a LearnedDynamicsConfig; None: the copy's own if it
    declares one, else the defaults) with `predictor` (None: that config's) and no shadow truth."""
    def edit(s):
        base = given if given is not None else s.effects.learned_dynamics
        config = dataclasses.replace(base) if base is not None else LearnedDynamicsConfig()
        s.effects.learned_dynamics = dataclasses.replace(config, predictor=predictor or config.predictor,
                                                         shadow_truth=False)
    return edit


def timing(time_step: float | None = None, duration: float | None = None):
    """plant.time_step [s] and/or duration [s] (None: unchanged)."""
    def edit(s):
        if time_step is not None:
            s.plant.time_step = float(time_step)
        if duration is not None:
            s.duration = float(duration)
    return edit
