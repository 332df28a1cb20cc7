"""`testbed compare SCENE`: the twin run (Drake's contact vs the learned closed loop)."""

from __future__ import annotations

from pathlib import Path

from learned_contact import sources
from testbed.commands import timestamp
from testbed.containers import HYDROELASTIC_MODULUS
from testbed.errors import TestbedError
from testbed.learned_force_law import law_modulus

NAME = "compare"
HELP = "run a scene with Drake's contact and with the learned model in the loop; write compare.json"


def add_arguments(parser) -> None:
    parser.add_argument("scene", help="a scene YAML file or the name of a shipped scene")
    parser.add_argument("--predictor", default=None,
                        help=f"{sources.HELP}; default: the scene's learned_dynamics predictor if it declares "
                             "one, else improved")
    parser.add_argument("--out", help="output directory (default reports/compare/<scene>-<predictor>-<time>)")
    parser.add_argument("--duration", type=float, help="simulated time [s] (default: the scene's)")
    parser.add_argument("--no-replay", action="store_true", help="skip the Meshcat ghost replay (replay.html)")
    parser.add_argument("--engine", choices=("learned", "mujoco"), default="learned",
                        help="what runs beside Drake: the learned closed loop (default) or MuJoCo")
    parser.add_argument("--params", choices=("matched", "default"), default="matched",
                        help="MuJoCo's contact parameters (with --engine mujoco): matched to Drake or MuJoCo's defaults")


def run(args) -> int:
    from testbed.compare import compare_scene
    from testbed.scenario import load_scenario, resolve_scene_path

    if args.duration is not None and not args.duration > 0:
        raise TestbedError(f"--duration: expected a positive number of seconds, got {args.duration}")
    path = resolve_scene_path(args.scene)
    scenario = load_scenario(path)
    if args.engine == "mujoco":  # testbed/engines/mujoco_compare.py (H-mujoco)
        from testbed.engines.mujoco_compare import compare_mujoco, format_mujoco_figures

        out = Path(args.out) if args.out else Path("reports") / "compare" / f"{scenario.name}-mujoco-{args.params}-{timestamp()}"
        print(format_mujoco_figures(compare_mujoco(scenario, params=args.params, out_dir=out, duration=args.duration,
                                                   replay=not args.no_replay, source=path)))
        print(f"  output: {out}")
        return 0
    declared = scenario.effects.learned_dynamics
    predictor = args.predictor or (declared.predictor if declared is not None else "improved")
    label = sources.label(predictor)
    out = Path(args.out) if args.out else Path("reports") / "compare" / f"{scenario.name}-{label}-{timestamp()}"
    figures = compare_scene(scenario, predictor=args.predictor, out_dir=out, duration=args.duration,
                            replay=not args.no_replay, source=path)
    print(format_figures(figures))
    print(f"  containers at {law_modulus(scenario):.0e} Pa in every run (the learned law's modulus; shipped SDF: "
          f"{HYDROELASTIC_MODULUS:.0e} Pa, sdf/README.md says why they differ)")
    print(f"  output: {out}")
    return 0


def format_figures(f: dict) -> str:
    """The few lines `testbed compare` prints."""
    verdict = "DIVERGED" if f["diverged"] else ("ran, but left Drake's path" if f["departed"] else "ran")
    from testbed.compare.costs import breakdown_line
    from testbed.compare.metrics import error_lines

    lines = [
        f"scene {f['scene']} with the {f['predictor']} predictor in the loop: {verdict} "
        f"({f['simulated_s_learned']:g} of {f['duration_s']:g} s)",
        *error_lines(f, "learned", f["wall_per_sim_s_learned"]),
    ]
    cost = breakdown_line(f.get("cost_learned"))
    if cost:
        slower = f.get("speedup_vs_truth", 1.0) < 1.0
        lines.append(f"  the learned run's wall time{' (not faster than Drake hydroelastic here)' if slower else ''}: {cost}")
    return "\n".join(lines)
