"""`testbed compare SCENE`: the twin run (Drake's contact vs the learned closed loop, or any
other registered engine: testbed/engines), judged by the closed-loop gates of `testbed validate`.

Exit status: 0 when every gate holds (or the learned model made no contact decision, so
there is nothing to judge), 3 when a gate fails or the learned run diverged
(testbed/compare/verdict.py), 2 for bad input.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import TYPE_CHECKING

from learned_contact import sources
from testbed.commands import timestamp
from testbed.engines import candidates
from testbed.errors import ScenarioError, TestbedError

if TYPE_CHECKING:
    from testbed.scenario import Scenario

NAME = "compare"
HELP = ("run a scene with Drake's contact and with the learned model in the loop, judge it by the closed-loop "
        "gates; write compare.json and report.html (exit 3 if a gate fails)")
PREDICTOR_FIELD = "effects.learned_dynamics.predictor"


def add_arguments(parser) -> None:
    parser.add_argument("scene", help="a scene YAML file or the name of a shipped scene")
    parser.add_argument("--predictor", default=None,
                        help=f"{sources.HELP}; default: the scene's learned_dynamics predictor if it declares "
                             "one, else improved (not with --engine mujoco)")
    parser.add_argument("--out", help="output directory (default reports/compare/<scene>-<predictor>-<time>)")
    parser.add_argument("--duration", type=float, help="simulated time [s] (default: the scene's)")
    parser.add_argument("--set", action="append", metavar="KEY=VALUE",
                        help="override a scene field, as `testbed run --set` (e.g. --set containers[1].mass=5000)")
    parser.add_argument("--no-replay", action="store_true", help="skip the Meshcat ghost replay (replay.html)")
    parser.add_argument("--no-truth", action="store_true",
                        help="no Drake run at all: time the candidates alone (wall time per simulated second, how far "
                             "each ran); nothing is judged (exit 0)")
    engines = candidates()  # the registered engines besides Drake's truth (testbed/engines)
    with_params = [e for e in engines.values() if e.param_sets]
    parser.add_argument("--engine", choices=(*engines, "all"), default="learned",
                        help="what runs beside Drake: the learned closed loop (default), another engine ("
                             f"{', '.join(e.label for e in engines.values() if not e.gated)}), or all: Drake point, "
                             "the learned loop and every other engine in one table against one Drake run at the "
                             "learned law's modulus (testbed/compare/candidates.py: all_candidates)")
    parser.add_argument("--params", choices=list(dict.fromkeys(p for e in with_params for p in e.param_sets)), default=None,
                        help="the engine's contact parameters (only with --engine "
                             f"{' or '.join(e.name for e in with_params)} or all): "
                             + "; ".join(f"{e.label}: {', '.join(e.param_sets)} (default {e.param_sets[0]})"
                                         for e in with_params))


def check_options(args) -> None:
    """Refuses options that do not apply to the chosen engine (TestbedError: exit 2)."""
    chosen = candidates().get(args.engine)
    if chosen is not None and not chosen.gated and not chosen.learned and args.predictor is not None:
        raise TestbedError(f"--predictor does not apply with --engine {args.engine} ({chosen.label} uses its own "
                           "contact, no predictor)")
    if chosen is not None and not chosen.param_sets and args.params is not None:
        names = " or ".join(n for n, e in candidates().items() if e.param_sets)
        raise TestbedError(f"--params applies only with --engine {names} or all (the {chosen.label} engine has no "
                           "contact-parameter sets)")
    if chosen is not None and args.params is not None and args.params not in chosen.param_sets:
        raise TestbedError(f"--params {args.params}: expected one of {', '.join(chosen.param_sets)} for --engine "
                           f"{args.engine}")
    if args.duration is not None and not args.duration > 0:
        raise TestbedError(f"--duration: expected a positive number of seconds, got {args.duration}")


@dataclasses.dataclass(frozen=True)
class ComparePlan:
    """What one `testbed compare` runs, read once from its options: the scene, the candidates
    beside Drake's truth (testbed/compare/candidates.py: Candidate) and how the one comparison
    (testbed/compare/run_candidates.py: compare_candidates) runs them.

    engine: --engine (a registered engine's name, or "all"); asked: --predictor as given (None:
    none); predictor: the spec the learned rows run (asked, else the scene's, else the shipped
    default); contacts: a non-gated engine's own contact rows are judged too; reference:
    "truth", or None with --no-truth (the candidates timed alone)."""

    scenario: Scenario
    source: str
    engine: str
    asked: str | None
    predictor: str
    candidates: list
    out_dir: Path
    duration: float | None
    reference: str | None
    contacts: bool
    replay: bool

    @classmethod
    def of(cls, args, scenario, source: str, predictor: str, lineup: list) -> ComparePlan:
        """The plan of the options `args` (checked: check_options) for the loaded scene, its
        resolved predictor and the candidates they name (printed.candidate_list)."""
        chosen = candidates().get(args.engine)  # None: all
        if args.out:
            out = Path(args.out)
        else:
            tag = _tag(args.engine, chosen, predictor, args.params) + ("-no-truth" if args.no_truth else "")
            out = Path("reports") / "compare" / f"{scenario.name}-{tag}-{timestamp()}"
        return cls(scenario=scenario, source=source, engine=args.engine, asked=args.predictor, predictor=predictor,
                   candidates=lineup, out_dir=out, duration=args.duration, reference=None if args.no_truth else "truth",
                   contacts=chosen is not None and not chosen.gated, replay=not args.no_replay)

    def options(self) -> dict:
        """compare_candidates' keywords of this plan (its `judge` comes from the command; the report,
        report.html and report.md, is written in every mode)."""
        return {"reference": self.reference, "duration": self.duration, "contacts": self.contacts,
                "out_dir": self.out_dir, "replay": self.replay, "source": self.source, "in_scene": True,
                "report": True}


def _tag(engine_name: str, chosen, predictor: str, params: str | None) -> str:
    """The default output directory's middle: what ran beside Drake."""
    if chosen is None or chosen.gated:  # the learned loop, alone or with every engine
        return sources.label(predictor) + ("-all" if engine_name == "all" else "")
    if chosen.learned:
        return f"{chosen.name}-{sources.label(predictor)}"
    return f"{chosen.name}-{params or chosen.param_sets[0]}" if chosen.param_sets else chosen.name


def run(args) -> int:
    from testbed.compare.candidates import predictor_for
    from testbed.compare.printed import candidate_list, compare_lines
    from testbed.compare.run_candidates import compare_candidates
    from testbed.compare.verdict import judge
    from testbed.scenario import load_scenario, resolve_scene_path, source_label

    check_options(args)
    path = resolve_scene_path(args.scene)
    scenario = load_scenario(path, overrides=args.set or [])
    if args.no_truth:  # no Drake run would check the scene: check it as `testbed run` does, before anything runs
        from testbed.builder import build_scene

        build_scene(scenario, source_label(path, args.set))
    predictor = predictor_for(scenario, args.predictor)  # once: the candidates and the output's name take it
    plan = ComparePlan.of(args, scenario, source_label(path, args.set), predictor,
                          candidate_list(args.engine, predictor, args.params, no_truth=args.no_truth))
    try:
        figures = compare_candidates(plan.scenario, plan.candidates, judge=judge, **plan.options())
    except ScenarioError as e:
        if plan.asked is not None and e.field == PREDICTOR_FIELD:  # the option, not the shipped file's field
            named = plan.asked in e.problem  # the loaders name the file or module:attribute already
            raise TestbedError(f"--predictor: {e.problem}" if named else f"--predictor {plan.asked}: {e.problem}") from None
        raise
    print("\n".join(compare_lines(figures, plan.out_dir)))
    if plan.engine == "all":
        from testbed.compare.candidates import unavailable_alternatives

        for label, why in unavailable_alternatives().items():
            print(f"  not run: {label}: {why}")
    return figures["exit_status"]

