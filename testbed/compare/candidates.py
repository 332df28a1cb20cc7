"""What runs beside the reference in a comparison: lists of candidates (Candidate,
testbed/engines/candidate.py: an engine, its contact-parameter set and, for a learned engine,
its predictor) for each `testbed compare` mode.

    from testbed.compare.candidates import Candidate, learned_loop
    compare_candidates(scenario, [Candidate.point(), learned_loop("paper")], ...)
"""

from __future__ import annotations

from learned_contact import sources
from testbed.engines import alternatives, engine
from testbed.engines.candidate import Candidate


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
