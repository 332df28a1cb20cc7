"""`testbed compare SCENE`: the twin run (Drake's contact vs the learned closed loop, or any
other registered engine: testbed/engines), judged by the closed-loop gates of `testbed validate`.

Exit status: 0 when every gate holds (or the learned model made no contact decision, so
there is nothing to judge), 3 when a gate fails or the learned run diverged
(testbed/validation/compare_verdict.py), 2 for bad input.
"""

from __future__ import annotations

from pathlib import Path

from learned_contact import sources
from testbed.bodies.containers import HYDROELASTIC_MODULUS
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
    engines = candidates()  # the registered engines besides Drake's truth (testbed/engines)
    with_params = [e for e in engines.values() if e.param_sets]
    parser.add_argument("--engine", choices=(*engines, "all"), default="learned",
                        help="what runs beside Drake: the learned closed loop (default), another engine ("
                             f"{', '.join(e.label for e in engines.values() if not e.gated)}), or all: Drake point, "
                             "the learned loop and every other engine in one table against one Drake run at the "
                             "learned law's modulus (testbed/engines/three_way.py)")
    parser.add_argument("--params", choices=list(dict.fromkeys(p for e in with_params for p in e.param_sets)), default=None,
                        help="the engine's contact parameters (only with --engine "
                             f"{' or '.join(e.name for e in with_params)} or all): "
                             + "; ".join(f"{e.label}: {', '.join(e.param_sets)} (default {e.param_sets[0]})"
                                         for e in with_params))


def check_options(args) -> None:
    """Refuses options that do not apply to the chosen engine (TestbedError: exit 2)."""
    chosen = candidates().get(args.engine)
    if chosen is not None and not chosen.gated and not getattr(chosen, "learned", False) and args.predictor is not None:
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


def run(args) -> int:
    from testbed.compare import compare_scene
    from testbed.scenario import load_scenario, resolve_scene_path, source_label
    from testbed.validation.compare_verdict import judge

    check_options(args)
    path = resolve_scene_path(args.scene)
    scenario = load_scenario(path, overrides=args.set or [])
    source = source_label(path, args.set)
    chosen = candidates().get(args.engine)
    if chosen is not None and not chosen.gated:  # another engine against Drake: testbed/engines/comparison.py
        from testbed.engines.comparison import compare_engine, format_engine_figures

        params = args.predictor or args.params or (chosen.param_sets[0] if chosen.param_sets else None)
        tag = f"{chosen.name}-{sources.label(params) if args.predictor else params}" if params else chosen.name
        out = Path(args.out) if args.out else Path("reports") / "compare" / f"{scenario.name}-{tag}-{timestamp()}"
        figures = compare_engine(scenario, chosen.name, params=params, out_dir=out, duration=args.duration,
                                 replay=not args.no_replay, source=source)
        print(format_engine_figures(figures))
        print(f"  output: {out}")
        if getattr(chosen, "learned", False):  # a predictor decides its contact: the closed-loop gates judge it
            return _judge_learned_engine(figures, out, chosen.name)
        print(f"verdict: none (the closed-loop gates judge a learned model in the loop; `--engine all` puts "
              f"{chosen.label} beside it against the same Drake run)")
        return 0
    declared = scenario.effects.learned_dynamics
    predictor = args.predictor or (declared.predictor if declared is not None else sources.DEFAULT)
    label = sources.label(predictor) + ("-all" if args.engine == "all" else "")
    out = Path(args.out) if args.out else Path("reports") / "compare" / f"{scenario.name}-{label}-{timestamp()}"
    verdict = judge
    if args.engine == "all":  # one Drake reference at one modulus for point, learned, MuJoCo
        from testbed.engines import three_way

        three_way.check_three_way(scenario)
        scenario = three_way.at_law_modulus(scenario)
        params = args.params or "matched"

        def verdict(figures, directory, runs):
            return {**judge(figures, directory), "three_way": three_way.rows(scenario, figures, runs, params, predictor)}
    try:
        figures = compare_scene(scenario, predictor=args.predictor, out_dir=out, duration=args.duration,
                                replay=not args.no_replay, source=source, judge=verdict)
    except ScenarioError as e:
        if args.predictor is not None and e.field == PREDICTOR_FIELD:  # the option, not the shipped file's field
            named = args.predictor in e.problem  # the loaders name the file or module:attribute already
            raise TestbedError(f"--predictor: {e.problem}" if named else f"--predictor {args.predictor}: {e.problem}") from None
        raise
    print(format_figures(figures, out))
    return figures["exit_status"]


def _judge_learned_engine(figures: dict, out, name: str) -> int:
    """Prints the closed-loop gates' verdict on a learned engine's compare run (its series are
    written as the learned loop's, testbed/engines/comparison.py) and returns the exit status."""
    import json

    from testbed.records import write_json
    from testbed.validation.compare_verdict import judge, verdict_lines

    f = {**figures, "simulated_s_learned": figures[f"simulated_s_{name}"],
         "drift_m_per_min_learned": figures.get(f"drift_m_per_min_{name}"), "learned_error": figures.get(f"{name}_error"),
         "wall_per_sim_s_learned": figures[f"wall_per_sim_s_{name}"]}
    f.update(judge(f, out))
    path = Path(out) / "compare.json"
    saved = json.loads(path.read_text())
    saved.update({k: f[k] for k in ("verdict", "exit_status", "gates", "gates_failed", "gates_not_judged",
                                    "gates_known_limits", "leaves_truth_at_s", "energy_gain_gated_J", "energy_limit_J")})
    write_json(path, saved)
    print("\n".join(verdict_lines(f)))
    return f["exit_status"]


def modulus_line(modulus: float, why: str) -> str:
    """The hydroelastic modulus every mode prints (the figures are against a truth at it)."""
    return f"  Drake's containers at a hydroelastic modulus of {modulus:.0e} Pa ({why})"


def format_figures(f: dict, out=None) -> str:
    """The lines `testbed compare` prints: what happened, the figures, the output directory
    `out`, the gates, and last the verdict."""
    from testbed.compare.costs import breakdown_line
    from testbed.compare.metrics import error_lines
    from testbed.validation.compare_verdict import NOT_JUDGED, headline, verdict_lines

    lines = [f"scene {f['scene']} with the {f['predictor']} predictor in the loop: {headline(f)} "
             f"({f['simulated_s_learned']:g} of {f['duration_s']:g} s simulated)"]
    errors = error_lines(f, "learned", f["wall_per_sim_s_learned"])
    lines += errors[1:] if f["verdict"] == NOT_JUDGED else errors  # no position error "score" for 0 decisions
    cost = breakdown_line(f.get("cost_learned"))
    if cost and f["verdict"] != NOT_JUDGED:
        slower = f.get("speedup_vs_truth", 1.0) < 1.0
        lines.append(f"  the learned run's wall time{' (not faster than Drake hydroelastic here)' if slower else ''}: {cost}")
    if f["hydroelastic_modulus_Pa"] == HYDROELASTIC_MODULUS:
        why = "the shipped containers', in every run of this comparison"
    else:
        why = (f"in every run of this comparison, not the shipped {HYDROELASTIC_MODULUS:.0e} Pa: the learned law's "
               "default, at which it was fitted and judged; the truth is made as soft as the law it is compared with "
               "(docs/commands.md)")
    lines.append(modulus_line(f["hydroelastic_modulus_Pa"], why))
    if f.get("truth_reference") == "continuous":
        lines.append(f"  the truth: Drake's continuous-time plant (triangle contact surfaces, exact moments; RungeKutta3 at "
                     f"accuracy {f['truth_accuracy']:g}): this scene's discrete answer depends on the contact mesh "
                     "(testbed study truth; docs/truth.md)")
    elif "truth_reference" in f:
        lines.append("  the truth: Drake's discrete plant as the scene sets it (each contact polygon's force at its "
                     "centroid; how far that is from a converged answer: testbed study truth)")
    if "three_way" in f:
        from testbed.engines.three_way import format_table

        lines += format_table(f["three_way"])
    if out is not None:
        lines.append(f"  output: {out}")
    lines += verdict_lines(f)
    return "\n".join(lines)

