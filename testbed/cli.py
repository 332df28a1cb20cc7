"""The `testbed` command line.

  testbed scenes                         list the shipped scenes
  testbed run SCENE [--out DIR] [--duration S] [--set key=value ...]
  testbed run-all [--out DIR] [--duration S] [--models hydroelastic point]
  testbed view SCENE [--port P] [--host H] [--rate R]     (Meshcat, until Ctrl-C)
  testbed validate [--suite default|full] [--workers N] [--executor local|ray]
                   [--address A] [--resume RUN_DIR]       (the main job)
  testbed study sim|query|stability [--out DIR] [--quick]
  testbed train [--out DIR] [--seed N]                    (needs the `train` extra: torch)

Errors in the user's input (scene files, overrides, options) print one line naming
the file and field and exit with status 2; a simulation that fails (solver
divergence) exits with status 1. Nothing is left half-written.
"""

from __future__ import annotations

import argparse
import datetime
import sys
from pathlib import Path

from testbed.errors import SimulationError, TestbedError


def _timestamp() -> str:
    return datetime.datetime.now().strftime("%Y%m%d-%H%M%S")


def _format_summary(summary: dict) -> str:
    lines = [
        f"scene {summary['scene']}: {summary['steps']} steps of {summary['time_step_s'] * 1e3:g} ms, "
        f"wall {summary['wall_time_s']:.2f} s, real-time factor {summary['real_time_factor']:.2f}",
        f"  contact model: {summary['contact_model']} ({summary['approximation']}); effects: {', '.join(summary['effects'])}",
    ]
    if "contact_rows" in summary:
        lines.append(
            f"  contacts: {summary['contact_rows']} rows, up to {summary['max_contacts_per_step']} per step; "
            f"max penetration {summary['max_penetration_m'] * 1e3:.3f} mm"
        )
    else:
        lines.append("  contacts: not recorded (declare the contact_log effect)")
    if "shadow_cop_distance_max_m" in summary:
        lines.append(
            f"  shadow ({summary['shadow_model']}): worst centre-of-pressure disagreement "
            f"{summary['shadow_cop_distance_max_m'] * 100:.1f} cm at step {summary['shadow_worst_step']}, "
            f"max normal angle {summary['shadow_normal_angle_max_deg']:.2f} deg"
        )
    if not summary.get("finite_state", True):
        lines.append("  WARNING: the final state is not finite (the simulation diverged)")
    return "\n".join(lines)


def cmd_scenes(args) -> int:
    from testbed.scenario import load_scenario, shipped_scenes

    for name, path in shipped_scenes().items():
        scenario = load_scenario(path)
        print(f"{name:20s} {len(scenario.containers)} containers, {scenario.duration:g} s, "
              f"effects: {', '.join(scenario.declared_effects())}\n{'':20s} {scenario.description}")
    return 0


def cmd_run(args) -> int:
    from testbed.scenario import load_scenario, resolve_scene_path
    from testbed.simulation import run_scenario

    path = resolve_scene_path(args.scene)
    scenario = load_scenario(path, overrides=args.set or [])
    if args.duration is not None and not args.duration > 0:
        raise TestbedError(f"--duration: expected a positive number of seconds, got {args.duration}")
    out = Path(args.out) if args.out else Path("reports") / "runs" / f"{scenario.name}-{_timestamp()}"
    result = run_scenario(scenario, out_dir=out, duration=args.duration, progress=not args.quiet, source=path)
    print(_format_summary(result.summary))
    print(f"  records: {out}")
    return 0


def cmd_run_all(args) -> int:
    from testbed.batch import run_all

    out = Path(args.out) if args.out else Path("reports") / f"run-all-{_timestamp()}"
    report = run_all(out, duration=args.duration, models=args.models, progress=not args.quiet)
    print(report)
    print(f"report: {out}")
    return 0


def cmd_validate(args) -> int:
    from testbed.validate import validate

    run_dir, metrics = validate(suite_name=args.suite, workers=args.workers, executor=args.executor,
                                address=args.address, resume=args.resume, progress=not args.quiet)
    print((run_dir / "summary.md").read_text())
    print(f"report: {run_dir / 'index.html'}")
    return 0 if metrics["passed"] else 3


def cmd_study(args) -> int:
    out = Path(args.out) if args.out else Path("reports") / f"study-{args.which}-{_timestamp()}"
    out.mkdir(parents=True, exist_ok=True)
    if args.which == "stability":
        import json

        from testbed.report import stability_matrix
        from testbed.studies.stability import matrix_cases, run_matrix_entry

        grid = matrix_cases(quick=args.quick)
        if not args.quiet:
            from tqdm import tqdm

            grid = tqdm(grid, desc="stability matrix")
        rows = [run_matrix_entry(name, kw) for name, kw in grid]
        (out / "stability.json").write_text(json.dumps(rows, indent=1, default=float))
        columns, table = stability_matrix(rows)
        md = ["| case | " + " | ".join(columns) + " |", "|---" * (len(columns) + 1) + "|"]
        md += ["| " + " | ".join(row) + " |" for row in table]
        (out / "stability.md").write_text("\n".join(md) + "\n")
        for r in rows:
            if not r["stable"]:
                print(f"UNSTABLE {r['case']} / {r['model']} / {r['approximation']} / h={r['time_step']:g}: {r['failed']}")
        print(f"{sum(r['stable'] for r in rows)} of {len(rows)} stable")
    elif args.which == "query":
        from testbed.studies.query import run_query_study

        run_query_study(out, quick=args.quick, progress=not args.quiet)
        print((out / "query.md").read_text())
    else:
        import json

        from testbed.studies.sim import effect_costs, sweep

        steps = [1e-3, 3e-3, 1e-2] if args.quick else [2e-4, 5e-4, 1e-3, 2e-3, 5e-3, 1e-2]
        rows = sweep(args.scene, models=["hydroelastic", "point"], approximations=["sap", "tamsi", "similar", "lagged"],
                     time_steps=steps, reference_step=1e-4, duration=0.5 if args.quick else 1.0, progress=not args.quiet)
        costs = effect_costs(args.scene, duration=0.3 if args.quick else 1.0)
        (out / "sim.json").write_text(json.dumps({"sweep": rows, "effect_costs": costs}, indent=1))
        for r in rows:
            print(f"{r['model']:13s} {r['approximation']:7s} h={r['time_step']:<7g} {r['ms_per_sim_second']:8.0f} ms/sim s  "
                  f"deviation {r['deviation_m'] * 1e3:9.3f} mm  {r['status']}")
        for r in costs:
            print(f"effect {r['effect']:16s} " + (f"{r['ratio']:.2f}x" if r.get("status") == "ok" else str(r.get("status"))))
    print(f"study output: {out}")
    return 0


def cmd_train(args) -> int:
    try:
        import torch  # noqa: F401
    except ImportError:
        from testbed.errors import OptionalDependencyError

        raise OptionalDependencyError("torch", "testbed train", "train") from None
    from learned_contact.training import train_default

    out = Path(args.out) if args.out else Path("reports") / f"train-{_timestamp()}"
    metrics = train_default(out, seed=args.seed, progress=not args.quiet)
    print((out / "report.md").read_text())
    print(f"trained model: {out} (wall time {metrics['wall_time_s']['total']:.0f} s); "
          f"to ship it: copy its files into learned_contact/shipped/")
    return 0


def cmd_view(args) -> int:
    from testbed.viewer import view

    if args.duration is not None and not args.duration > 0:
        raise TestbedError(f"--duration: expected a positive number of seconds, got {args.duration}")
    view(args.scene, port=args.port, host=args.host, rate=args.rate, overrides=args.set or [],
         duration=args.duration, out=args.out)
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="testbed", description="Container contact testbed (Drake).")
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("scenes", help="list the shipped scenes").set_defaults(func=cmd_scenes)
    run = sub.add_parser("run", help="simulate one scene and write its records")
    run.add_argument("scene", help="a scene YAML file or the name of a shipped scene")
    run.add_argument("--out", help="output directory (default reports/runs/<scene>-<time>)")
    run.add_argument("--duration", type=float, help="simulated time [s] (default: the scene's)")
    run.add_argument("--set", action="append", metavar="KEY=VALUE",
                     help="override a scene field, e.g. --set effects.contact.model=point --set containers[0].mass=25000")
    run.add_argument("--quiet", action="store_true", help="no progress bar")
    run.set_defaults(func=cmd_run)
    run_all = sub.add_parser("run-all", help="run every shipped scene under each contact model; write a summary report")
    run_all.add_argument("--out", help="report directory (default reports/run-all-<time>)")
    run_all.add_argument("--duration", type=float, help="override every scene's simulated time [s]")
    run_all.add_argument("--models", nargs="+", default=["hydroelastic", "point"],
                         help="contact models to run each scene with (default: hydroelastic point)")
    run_all.add_argument("--quiet", action="store_true", help="no progress bars")
    run_all.set_defaults(func=cmd_run_all)
    v = sub.add_parser("view", help="simulate a scene live in the Meshcat viewer, write its replay, serve until Ctrl-C")
    v.add_argument("scene", help="a scene YAML file or the name of a shipped scene")
    v.add_argument("--port", type=int, default=7000, help="TCP port (default 7000; 0 = any free port)")
    v.add_argument("--host", default="localhost",
                   help="interface to listen on (default localhost; others warn: Meshcat has no authentication)")
    v.add_argument("--rate", type=float, default=1.0, help="target real-time rate (1 = real time, 0 = as fast as possible)")
    v.add_argument("--duration", type=float, help="simulated time [s] (default: the scene's)")
    v.add_argument("--out", help="run directory (default reports/runs/<scene>-view-<time>)")
    v.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a scene field")
    v.set_defaults(func=cmd_view)
    val = sub.add_parser("validate", help="run a validation suite and write reports/<time>/ (exit 3 if a gate fails)")
    val.add_argument("--suite", default="default", help="default (about 10 min on 2 cores), full, or smoke (seconds)")
    val.add_argument("--workers", type=int, default=2, help="worker processes (default 2)")
    val.add_argument("--executor", default="local", help="local (process pool) or ray")
    val.add_argument("--address", help="Ray cluster address (with --executor ray); default: start a local Ray")
    val.add_argument("--resume", metavar="RUN_DIR", help="finish an interrupted run: compute only its missing cases")
    val.add_argument("--quiet", action="store_true", help="no progress bar")
    val.set_defaults(func=cmd_validate)
    study = sub.add_parser("study", help="one study on its own: sim (time step x model x approximation) or query")
    study.add_argument("which", choices=["sim", "query", "stability"])
    study.add_argument("--scene", default="two_stack", help="scene of the sim study (default two_stack)")
    study.add_argument("--out", help="output directory (default reports/study-<which>-<time>)")
    study.add_argument("--quick", action="store_true", help="a small grid (about a minute)")
    study.add_argument("--quiet", action="store_true", help="no progress bars")
    study.set_defaults(func=cmd_study)
    train = sub.add_parser("train", help="train the learned predictors from a seed (reproduces learned_contact/shipped)")
    train.add_argument("--out", help="output directory (default reports/train-<time>)")
    train.add_argument("--seed", type=int, default=0, help="seed of the shipped model: 0")
    train.add_argument("--quiet", action="store_true", help="no progress bars")
    train.set_defaults(func=cmd_train)
    return parser


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except SimulationError as e:
        print(f"testbed: simulation failed: {e}", file=sys.stderr)
        return 1
    except TestbedError as e:
        print(f"testbed: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("testbed: interrupted; no output was written", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
