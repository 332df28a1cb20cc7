"""Drake behind the Engine protocol: `drake` (the ground truth, any of its contact models)
and `learned` (the learned closed loop: Drake's plant with the learned_dynamics effect).

The registration stays light (the CLI's parser lists the engines without loading Drake);
run.py holds the runs.
"""

from __future__ import annotations

from testbed.engines import register
from testbed.engines.base import Engine


@register
class DrakeEngine(Engine):
    """Drake's MultibodyPlant; params: a contact model (effects/contact.py CONTACT_MODELS;
    None: the scene's own)."""

    name = "drake"
    label = "Drake"
    order = 0
    reference = True

    def run(self, scenario, *, duration=None, record_every=1, params=None, contacts=False, source="<scenario>"):
        from testbed.engines.drake import run

        return run.run(self.name, scenario, duration=duration, record_every=record_every, params=params,
                       contacts=contacts, source=source)


@register
class LearnedEngine(DrakeEngine):
    """Drake with the learned closed loop; params: the predictor (None: the scene's
    learned_dynamics predictor if it declares one, else "improved")."""

    name = "learned"
    label = "learned"
    order = 10
    reference = False
    gated = True
