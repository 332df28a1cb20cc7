"""Drake's runs for the Engine protocol (testbed/engines/drake/__init__.py registers them).

The scenario is run as given, after `prepared` (a contact model for `drake`, the learned
closed loop for `learned`), through the one sampled-run loop,
testbed.simulation.record_run. Contact rows come from the contact_log effect (a
RECORDER, added here every `record_every` steps when asked for), whose logging is then
inside the wall time.
"""

from __future__ import annotations

from testbed import variants
from testbed.builder import build_scene
from testbed.effects.contact_log import ContactLogConfig
from testbed.engines.base import EngineRun
from testbed.simulation import record_run


def prepared(name: str, scenario, params: str | None):
    """The scenario engine `name` builds: 'drake' with contact model `params` (None: the
    scene's own), 'learned' with the learned loop and predictor `params` (None: the
    scene's learned_dynamics predictor if it declares one, else "improved")."""
    if name == "learned":
        return variants.derive(scenario, variants.learned_loop(params))
    return variants.derive(scenario, variants.contact(params)) if params is not None else scenario


def _contact_log(every: int):
    def edit(s):
        s.effects.contact_log = ContactLogConfig(every_steps=every)
    return edit


def run(name: str, scenario, *, duration=None, record_every=1, params=None, contacts=False,
        source="<scenario>") -> EngineRun:
    """Engine.run for the Drake engine `name` (see testbed/engines/base.py)."""
    s = prepared(name, scenario, params)
    if contacts:
        s = variants.derive(s, _contact_log(record_every))
    scene = build_scene(s, source)
    trajectory = record_run(scene, s.duration if duration is None else float(duration), record_every)
    rows = scene.effects["contact_log"].logger.tables()["contacts"] if contacts else None
    wall = trajectory.wall_s / max(trajectory.simulated_s, 1e-12)
    return EngineRun(trajectory, rows, {"engine": name, "wall_per_sim_s": wall})
