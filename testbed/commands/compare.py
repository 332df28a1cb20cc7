"""`testbed compare SCENE`: the twin run (Drake's contact vs the learned closed loop, or any
other registered engine: testbed/engines), judged by the closed-loop gates of `testbed validate`.

Exit status: 0 when every gate holds (or the learned model made no contact decision, so
there is nothing to judge), 3 when a gate fails or the learned run diverged
(testbed/validation/compare_verdict.py), 2 for bad input.
"""

from __future__ import annotations

from pathlib import Path

from learned_contact import sources
from testbed.commands import timestamp
from testbed.engines import candidates
from testbed.errors import ScenarioError, TestbedError

NAME = "compare"
HELP = ("run a scene with Drake's contact and with the learned model in the loop, judge it by the closed-loop "
        "gates; write compare.json (exit 3 if a gate fails)")
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


def _out_dir(args, scenario, chosen, predictor: str) -> Path:
    if args.out:
        return Path(args.out)
    if chosen is None or chosen.gated:  # the learned loop, alone or with every engine
        tag = sources.label(predictor) + ("-all" if args.engine == "all" else "")
    elif chosen.learned:
        tag = f"{chosen.name}-{sources.label(predictor)}"
    else:
        tag = f"{chosen.name}-{args.params or chosen.param_sets[0]}" if chosen.param_sets else chosen.name
    return Path("reports") / "compare" / f"{scenario.name}-{tag}{'-no-truth' if args.no_truth else ''}-{timestamp()}"


def run(args) -> int:
    from testbed.compare import compare_candidates
    from testbed.compare.candidates import predictor_for
    from testbed.compare.printed import candidate_list
    from testbed.scenario import load_scenario, resolve_scene_path, source_label
    from testbed.validation.compare_verdict import judge

    check_options(args)
    path = resolve_scene_path(args.scene)
    scenario = load_scenario(path, overrides=args.set or [])
    source = source_label(path, args.set)
    chosen = candidates().get(args.engine)
    chosen_list = candidate_list(scenario, args.engine, args.predictor, args.params, no_truth=args.no_truth)
    out = _out_dir(args, scenario, chosen, predictor_for(scenario, args.predictor))
    try:
        figures = compare_candidates(scenario, chosen_list, reference=None if args.no_truth else "truth",
                                     duration=args.duration, contacts=chosen is not None and not chosen.gated,
                                     out_dir=out, replay=not args.no_replay, source=source, judge=judge, in_scene=True)
    except ScenarioError as e:
        if args.predictor is not None and e.field == PREDICTOR_FIELD:  # the option, not the shipped file's field
            named = args.predictor in e.problem  # the loaders name the file or module:attribute already
            raise TestbedError(f"--predictor: {e.problem}" if named else f"--predictor {args.predictor}: {e.problem}") from None
        raise
    print(format_figures(figures, out))
    if args.engine == "all":
        from testbed.compare.candidates import unavailable_alternatives

        for label, why in unavailable_alternatives().items():
            print(f"  not run: {label}: {why}")
    return figures["exit_status"]


def format_figures(f: dict, out=None) -> str:
    """The lines `testbed compare` prints of compare.json `f` (testbed/compare/printed.py), and
    last the closed-loop gates and the verdict (testbed/validation/compare_verdict.py)."""
    from testbed.compare.printed import figure_lines
    from testbed.compare.run_candidates import NO_REFERENCE
    from testbed.validation.compare_verdict import NOT_JUDGED, headline, verdict_lines

    judged = f["verdict"] not in (None, NO_REFERENCE)
    lines = figure_lines(f, out, head=headline(f) if judged else "", not_judged=f["verdict"] == NOT_JUDGED)
    return "\n".join(lines + (verdict_lines(f) if judged else []))
