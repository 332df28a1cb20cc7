"""What runs beside the reference in a comparison: a Candidate names an engine
(testbed/engines), its contact-parameter set and, for a learned engine, its predictor.

    from testbed.compare.candidates import Candidate
    compare_candidates(scenario, [Candidate.point(), Candidate.of("learned", predictor="paper")], ...)

`gated` (the closed-loop gates judge it: the learned loop) and `learned` (a predictor decides
its container contact) are the engine's declared class fields (testbed/engines/base.py).
"""

from __future__ import annotations

import dataclasses

from learned_contact import sources
from testbed.engines import alternatives, engine


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


def predictor_for(scenario, predictor: str | None) -> str:
    """The predictor spec a learned candidate of `scenario` runs: `predictor`, else the scene's
    learned_dynamics predictor if it declares one, else the shipped default."""
    declared = scenario.effects.learned_dynamics
    return predictor or (declared.predictor if declared is not None else sources.DEFAULT)


def learned_loop(predictor: str) -> Candidate:
    """The learned closed loop in Drake with `predictor` (gated)."""
    return Candidate("learned", predictor=predictor)


def engine_candidates(name: str, *, params: str | None = None, predictor: str | None = None,
                      with_point: bool = True) -> list[Candidate]:
    """[engine `name`'s Candidate (params for an engine with contact-parameter sets, predictor
    for a learned one), Drake point (when `with_point`)]: `testbed compare --engine NAME`."""
    e = engine(name)
    chosen = Candidate(name, params=None if e.learned else params, predictor=predictor if e.learned else None)
    return [chosen, *([Candidate.point()] if with_point else [])]


def unavailable_alternatives() -> dict[str, str]:
    """{engine label: why it cannot run here} of the engines `--engine all` leaves out."""
    return {e.label: why for e in alternatives() if (why := e.unavailable()) is not None}


def all_candidates(predictor: str, params: str = "matched") -> list[Candidate]:
    """`testbed compare --engine all`: Drake point, the learned loop with `predictor`, then every
    other engine (testbed.engines.alternatives): a learned one with that same `predictor` (every
    learned row answers with the user's model), one with contact-parameter sets with `params`
    where it has that set (else its first). An engine that cannot run here (its optional package
    missing: Engine.unavailable) is left out; unavailable_alternatives says which and why."""
    out = [Candidate.point(), learned_loop(predictor)]
    for e in alternatives():
        if e.unavailable() is not None:
            continue
        if e.learned:
            out.append(Candidate(e.name, predictor=predictor))
        else:
            out.append(Candidate(e.name, params=params if params in e.param_sets else None))
    return out
