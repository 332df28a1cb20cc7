"""Drake's runs for the Engine protocol (testbed/engines/drake/__init__.py registers them).

The scenario is run as given, after `prepared` (a contact model, and for `learned` the learned
closed loop with its predictor), through the one sampled-run loop,
testbed.simulation.record_run. Contact rows come from the contact_log effect (a
RECORDER, added here every `record_every` steps when asked for), whose logging is then
inside the wall time.
"""

from __future__ import annotations

import dataclasses

from testbed import variants
from testbed.builder import build_scene
from testbed.effects.contact_log import ContactLogConfig
from testbed.engines.base import EngineRun
from testbed.simulation import record_run


def prepared(name: str, scenario, params: str | None, predictor: str | None = None):
    """The scenario engine `name` builds: contact model `params` (None: the scene's own), and
    for 'learned' the learned loop with `predictor` (None: the scene's learned_dynamics
    predictor if it declares one, else "improved")."""
    edits = [variants.contact(params)] if params is not None else []
    if name == "learned":
        edits.append(variants.learned_loop(predictor))
    return variants.derive(scenario, *edits) if edits else scenario


def with_contact_log(every: int):
    """An edit: the contact_log effect (a RECORDER) on, logging every `every` plant steps."""
    def edit(s):
        s.effects.contact_log = ContactLogConfig(every_steps=every)
    return edit


def run(name: str, scenario, *, duration=None, record_every=1, params=None, predictor=None, contacts=False,
        source="<scenario>") -> EngineRun:
    """Engine.run for the Drake engine `name` (see testbed/engines/base.py); the learned loop's
    summary adds what its effect decided (learned_summary)."""
    s = prepared(name, scenario, params, predictor)
    if contacts:
        s = variants.derive(s, with_contact_log(record_every))
    scene = build_scene(s, source)
    trajectory = record_run(scene, s.duration if duration is None else float(duration), record_every)
    rows = scene.effects["contact_log"].logger.tables()["contacts"] if contacts else None
    wall = trajectory.wall_s / max(trajectory.simulated_s, 1e-12)
    summary = {"engine": name, "wall_per_sim_s": wall}
    if name == "learned":
        summary.update(learned_summary(scene.effects["learned_dynamics"]))
    return EngineRun(trajectory, rows, summary)


def learned_summary(effect) -> dict:
    """The learned loop's own figures: predictor (the spec run) and predictor_kind, the
    container pairs it watches, its explicit step's stability rows and their largest ratio
    (stability_max), its config (learned_dynamics_config). Its cost counters are the
    trajectory's `costs`."""
    return {"predictor": effect.config.predictor,
            "predictor_kind": getattr(effect.predictor, "kind", effect.config.predictor),  # a user model may not say
            "container_pairs": len(effect.pairs),
            "stability_max": max((r["explicit"] for r in effect.stability), default=0.0),
            "learned_dynamics_config": dataclasses.asdict(effect.config),
            "stability": [{**r, "pair": list(r["pair"])} for r in effect.stability]}
