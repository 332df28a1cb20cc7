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
    None: the scene's own); no predictor."""

    name = "drake"
    label = "Drake"
    order = 0
    reference = True
    drake_hosted = True

    def run(self, scenario, *, duration=None, record_every=1, params=None, predictor=None, contacts=False,
            source="<scenario>"):
        from testbed.engines.drake import run

        self.refuse_unused(None, predictor)  # params: any contact model Drake knows (the builder checks it)
        return run.run(self.name, scenario, duration=duration, record_every=record_every, params=params,
                       predictor=predictor, contacts=contacts, source=source)


@register
class LearnedEngine(DrakeEngine):
    """Drake with the learned closed loop; predictor: its spec (None: the scene's
    learned_dynamics predictor if it declares one, else "improved"); params: a contact model
    for the rest of the scene's contact (None: the scene's own)."""

    name = "learned"
    label = "learned"
    order = 10
    reference = False
    gated = True
