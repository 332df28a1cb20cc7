"""A Candidate: one run beside a reference, named explicitly as an engine (testbed/engines),
its contact-parameter set and, for a learned engine, its predictor. The comparison
(testbed/compare) runs lists of them against one truth run; the scale study times them
(testbed/studies/scale/settings.py: its models).

`gated` (the closed-loop gates judge it: the learned loop) and `learned` (a predictor decides
its container contact) are the engine's declared class fields (testbed/engines/base.py).
"""

from __future__ import annotations

import dataclasses

from learned_contact import sources
from testbed.engines import engine


@dataclasses.dataclass(frozen=True)
class Candidate:
    """engine: a registered engine's name; params: one of its contact-parameter sets (Drake:
    a contact model; None: its default); predictor: a learned_contact.sources spec, only for a
    learned or gated engine (None there: the scene's learned_dynamics predictor if it declares
    one, else the shipped default); label: how tables and compare.json's `candidates` name it
    (unique within one comparison)."""

    engine: str
    params: str | None = None
    predictor: str | None = None
    label: str = ""

    def __post_init__(self):
        e = self.spec
        if self.predictor is not None and not (e.learned or e.gated):
            raise ValueError(f"candidate {self.engine}: a predictor applies only to a learned engine")
        if not self.label:
            object.__setattr__(self, "label", self.default_label())

    @property
    def spec(self):
        """The registered Engine instance."""
        return engine(self.engine)

    @property
    def gated(self) -> bool:
        return self.spec.gated

    @property
    def learned(self) -> bool:
        return self.spec.learned

    @property
    def judged(self) -> bool:
        """Judged by the closed-loop gates: a predictor decides its contact."""
        return self.gated or self.learned

    @property
    def run_params(self) -> str | None:
        """The params passed to Engine.run: the given set, else the engine's first (None: none)."""
        return self.params or (self.spec.param_sets[0] if self.spec.param_sets else None)

    def default_label(self) -> str:
        """'Drake point', 'learned (improved)', 'MuJoCo (matched)', 'MuJoCo + learned (paper)'."""
        e = self.spec
        if self.engine == "drake":
            return f"Drake {self.params or 'truth'}"
        shown = (self.predictor or sources.DEFAULT) if self.judged else self.run_params
        return f"{e.label} ({shown})" if shown else e.label

    @classmethod
    def point(cls) -> Candidate:
        """Drake point contact: the speed every learned run is set against."""
        return cls("drake", params="point", label="Drake point")
