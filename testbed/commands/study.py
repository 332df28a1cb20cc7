"""`testbed study sim|query|stability|defaults|scale|truth`: one study on its own, written to a directory."""

from __future__ import annotations

import json
from pathlib import Path

from testbed.commands import timestamp
from testbed.errors import TestbedError
from testbed.records import write_atomic

# The cube tosses shipped in the package (testbed/calibration/cube_tosses/, BSD-3-Clause, DAIRLab);
# the same path as testbed.calibration.data.SHIPPED_TOSSES, spelled out so the CLI's start imports no numpy.
DEFAULT_TOSS_DATA = Path(__file__).resolve().parents[1] / "calibration" / "cube_tosses" / "even.npz"

NAME = "study"
HELP = ("one study on its own: sim (time step x model x approximation), query, stability, defaults (contact settings "
        "judged over hard cases), scale (what a yard of N containers costs with each contact model) or truth (how far each "
        "scene's default truth is from a converged one, and what each rung of the truth ladder costs)")


def add_arguments(parser) -> None:
    parser.add_argument("which", choices=["sim", "query", "stability", "defaults", "scale", "truth"])
    parser.add_argument("--scene", default="two_stack", help="scene of the sim study (default two_stack)")
    parser.add_argument("--out", help="output directory (default reports/study-<which>-<time>)")
    parser.add_argument("--quick", action="store_true", help="a small grid (about a minute)")
    parser.add_argument("--quiet", action="store_true", help="no progress bars")
    parser.add_argument("--workers", type=int, default=2, help="processes of the defaults sweep and of scale's --executor local (default 2)")
    sweep = parser.add_argument_group("defaults sweep axes (comma-separated; default: the full grid)")
    sweep.add_argument("--moduli", help="hydroelastic moduli [Pa], e.g. 1e8,1e9")
    sweep.add_argument("--approximations", help="discrete approximations, e.g. sap,similar")
    sweep.add_argument("--margins", help="hydroelastic margins [m], e.g. 0,1e-4")
    sweep.add_argument("--time-steps", help="plant time steps [s], e.g. 1e-3")
    sweep.add_argument("--stiction-tolerances", help="plant stiction tolerances [m/s] (not SAP's), e.g. 1e-4,1e-6")
    sweep.add_argument("--cases", help="cases to run (default all: stress cases, shipped scenes, cube_tosses)")
    scale = parser.add_argument_group("scale study (testbed/studies/scale.py)")
    scale.add_argument("--sizes", help="containers per yard, multiples of --tiers (default 4,16,48,96,192; --quick 4,8,16)")
    scale.add_argument("--tiers", type=int, help="tiers of every yard block (default 4)")
    scale.add_argument("--duration", type=float, help="[s] simulated per run (default 0.2; --quick 0.03)")
    scale.add_argument("--big-duration", type=float, help="[s] simulated per run above --big-above containers (default 0.1)")
    scale.add_argument("--big-above", type=int, help="containers above which runs are --big-duration long (default 96)")
    scale.add_argument("--models", help="comma-separated, some of hydroelastic,point,learned,mujoco,mujoco_learned (default all)")
    scale.add_argument("--predictor", help="predictor of both learned loops (default: each engine's own, 'improved')")
    scale.add_argument("--executor", choices=["sequential", "local", "ray"], default="sequential",
                       help="where the cells run: sequential (default, in this process: undisturbed timings), local "
                            "(--workers processes) or ray (validate's executors; cells side by side share the machine)")
    scale.add_argument("--address", help="Ray cluster address for --executor ray (default: a local Ray started here)")
    truth = parser.add_argument_group("truth study (testbed/studies/truth/; --duration [s] replaces every scene's)")
    truth.add_argument("--scenes", help="comma-separated scene names or files (default: the overhang pair, two_stack, "
                                        "single_drop, crane_hard_landing, stack_slide_rest, crane_edge_landing; "
                                        "--quick overhang_hold,two_stack for 0.1 s)")
    truth.add_argument("--rungs", help="comma-separated, some of polygon,triangle,half_step,refined_L1,refined_L2,"
                                       "continuous (default all)")
    truth.add_argument("--accuracies", help="error-control accuracies of the continuous rung (default 1e-3,1e-4)")
    sweep.add_argument("--toss-data", default=str(DEFAULT_TOSS_DATA),
                       help="real cube tosses for the toss criterion (default: the shipped even-numbered "
                            "DAIR Lab tosses, testbed/calibration/cube_tosses/even.npz)")


def run(args) -> int:
    out = Path(args.out) if args.out else Path("reports") / f"study-{args.which}-{timestamp()}"
    if args.which == "defaults" and _wants_tosses(args):
        from testbed.calibration.data import load_tosses

        load_tosses(args.toss_data)  # checked before anything is written: CalibrationDataError -> exit 2
    if args.which == "scale":
        _scale(args, out)  # makes `out` once its options are checked
    elif args.which == "truth":
        _truth(args, out)  # makes `out` once its options and scenes are checked
    else:
        out.mkdir(parents=True, exist_ok=True)
        {"stability": _stability, "query": _query, "sim": _sim, "defaults": _defaults}[args.which](args, out)
    print(f"study output: {out}")
    return 0


def _wants_tosses(args) -> bool:
    """Whether the defaults sweep will run the cube_tosses case (the full case list, or --cases naming it)."""
    if args.cases:
        return "cube_tosses" in [c.strip() for c in args.cases.split(",")]
    return not args.quick


def _stability(args, out: Path) -> None:
    from testbed.document import Section, table, to_markdown
    from testbed.studies.stability import matrix_cases, run_matrix_entry, stability_matrix

    grid = matrix_cases(quick=args.quick)
    if not args.quiet:
        from testbed.progress import progress

        grid = progress(grid, desc="stability matrix")
    rows = [run_matrix_entry(name, kw) for name, kw in grid]
    write_atomic(out / "stability.json", json.dumps(rows, indent=1, default=float))
    columns, matrix = stability_matrix(rows)
    write_atomic(out / "stability.md", to_markdown("Stability matrix", [Section(None, [table(["case", *columns], matrix)])]))
    for r in rows:
        if not r["stable"]:
            print(f"UNSTABLE {r['case']} / {r['model']} / {r['approximation']} / h={r['time_step']:g}: {r['failed']}")
    print(f"{sum(r['stable'] for r in rows)} of {len(rows)} stable")


def _query(args, out: Path) -> None:
    from testbed.studies.query import run_query_study

    run_query_study(out, quick=args.quick, progress=not args.quiet)
    print((out / "query.md").read_text())


def _sim(args, out: Path) -> None:
    from testbed.drake_support import available
    from testbed.studies.sim import effect_costs, sweep

    steps = [1e-3, 3e-3, 1e-2] if args.quick else [2e-4, 5e-4, 1e-3, 2e-3, 5e-3, 1e-2]
    rows = sweep(args.scene, models=["hydroelastic", "point"], approximations=available(("sap", "tamsi", "similar", "lagged")),
                 time_steps=steps, reference_step=1e-4, duration=0.5 if args.quick else 1.0, progress=not args.quiet)
    costs = effect_costs(args.scene, duration=0.3 if args.quick else 1.0)
    write_atomic(out / "sim.json", json.dumps({"sweep": rows, "effect_costs": costs}, indent=1))
    for r in rows:
        print(f"{r['model']:13s} {r['approximation']:7s} h={r['time_step']:<7g} {r['ms_per_sim_second']:8.0f} ms/sim s  "
              f"deviation {r['deviation_m'] * 1e3:9.3f} mm  {r['status']}")
    for r in costs:
        print(f"effect {r['effect']:16s} " + (f"{r['ratio']:.2f}x" if r.get("status") == "ok" else str(r.get("status"))))


def _defaults(args, out: Path) -> None:
    import time

    from testbed.document import to_html, to_markdown
    from testbed.drake_support import missing_approximation
    from testbed.effects.contact import APPROXIMATIONS as CONTACT_APPROXIMATIONS
    from testbed.studies import defaults as d

    axes = {"moduli": _floats(args.moduli, "--moduli", d.MODULI),
            "approximations": _choices(args.approximations, "--approximations", CONTACT_APPROXIMATIONS, d.APPROXIMATIONS),
            "margins": _floats(args.margins, "--margins", d.MARGINS, minimum=0.0),
            "time_steps": _floats(args.time_steps, "--time-steps", d.TIME_STEPS),
            "stiction_tolerances": _floats(args.stiction_tolerances, "--stiction-tolerances", d.STICTION_TOLERANCES)}
    missing = [m for m in map(missing_approximation, axes["approximations"]) if m]
    if missing:  # 'tamsi' under Drake >= 1.57: say so before anything runs
        raise TestbedError(f"--approximations: {missing[0]}")
    cases = _choices(args.cases, "--cases", d.CASE_NAMES, ("near_parallel",) if args.quick else d.CASE_NAMES)
    toss_data = Path(args.toss_data) if d.TOSS_CASE in cases else None  # checked in run()
    start, partial = time.perf_counter(), out / "defaults_rows.jsonl"
    partial.write_text("")
    with partial.open("a") as f:  # each (setting, case) row as it arrives: a cut-short sweep keeps its rows
        rows = d.sweep(d.grid(args.quick, **axes), cases, workers=args.workers, toss_data=toss_data,
                       duration=0.3 if args.quick else None,
                       on_row=lambda r: (f.write(json.dumps(r, default=float) + "\n"), f.flush()))
    summary = d.summarize(rows)
    write_atomic(out / "defaults.json", json.dumps({"rows": rows, "summary": summary}, indent=1, default=float))
    sections = d.report_sections(summary, time.perf_counter() - start)
    write_atomic(out / "defaults.md", to_markdown("Contact defaults sweep", sections))
    write_atomic(out / "defaults.html", to_html("Contact defaults sweep", sections))
    print((out / "defaults.md").read_text())


def _scale(args, out: Path) -> None:
    """The scale study: its ScaleConfig from the options (--quick: the small grid; a bad value is a
    ScaleConfigError, exit 2, before anything runs), its cells, its report."""
    import dataclasses

    from testbed.studies import scale
    from testbed.validation.executors import map_calls

    given = {}
    if args.sizes:
        try:
            given["sizes"] = tuple(int(x) for x in args.sizes.split(","))
        except ValueError:
            raise scale.ScaleConfigError(f"--sizes: expected comma-separated whole numbers, got {args.sizes!r}") from None
    if args.models:
        given["models"] = _choices(args.models, "--models", tuple(scale.MODELS), ())
    for name in ("tiers", "duration", "big_duration", "big_above", "predictor"):
        if getattr(args, name) is not None:
            given[name] = getattr(args, name)
    config = dataclasses.replace(scale.QUICK if args.quick else scale.ScaleConfig(), **given)
    config.validate()
    if args.executor == "sequential":
        study = scale.run_study(config, progress=not args.quiet)
    else:
        def cells(fn, items, done):
            map_calls(fn, items, done, executor=args.executor, workers=args.workers, address=args.address)

        study = scale.run_study(config, map_cells=cells, executor=args.executor)
    scale.write_report(study, out)
    print("\n".join(scale.summary_lines(study)))


def _truth(args, out: Path) -> None:
    """The truth ladder: options checked (TestbedError), scenes loaded and built (ScenarioError)
    before anything runs or is written; the meshes cached under <out>/mesh_cache."""
    import math

    from testbed.studies.truth import report, run, rungs

    chosen = _choices(args.rungs, "--rungs", rungs.RUNGS, rungs.RUNGS)
    accuracies = _floats(args.accuracies, "--accuracies", rungs.DEFAULT_ACCURACIES)
    if any(not a < 1 for a in accuracies) or len(set(accuracies)) != len(accuracies):
        raise TestbedError(f"--accuracies: expected distinct numbers below 1, got {list(accuracies)}")
    if args.duration is not None and not (math.isfinite(args.duration) and 0 < args.duration <= 3600):
        raise TestbedError(f"--duration: expected a number of seconds in (0, 3600], got {args.duration}")
    names = [n.strip() for n in args.scenes.split(",") if n.strip()] if args.scenes else \
        list(run.QUICK_SCENES if args.quick else run.FULL_SCENES)
    if not names:
        raise TestbedError(f"--scenes: expected comma-separated scene names, got {args.scenes!r}")
    scenes = run.load_scenes(names, args.duration, args.quick)  # ScenarioError -> exit 2, nothing written

    def on_rung(scene, row):
        if not args.quiet:
            wall = f"{row['wall_s']:.2f} s" if row["wall_s"] is not None else row["error"][:100]
            print(f"  {scene} / {row['rung']}: {row['status']}, {wall}", flush=True)

    out.mkdir(parents=True, exist_ok=True)
    study = run.run_loaded(scenes, rungs=chosen, accuracies=accuracies, quick=args.quick,
                           cache_dir=out / "mesh_cache", on_rung=on_rung)
    report.write_report(study, out)
    print("\n".join(report.summary_lines(study)))


def _floats(text, option: str, default, minimum: float | None = None) -> tuple[float, ...]:
    """A comma-separated list of numbers (positive, or >= minimum when given)."""
    if not text:
        return tuple(default)
    try:
        values = tuple(float(x) for x in text.split(","))
    except ValueError:
        raise TestbedError(f"{option}: expected comma-separated numbers, got {text!r}") from None
    bad = [v for v in values if not (v >= minimum if minimum is not None else v > 0)]
    if bad:
        raise TestbedError(f"{option}: expected {'non-negative' if minimum is not None else 'positive'} numbers, got {bad}")
    return values


def _choices(text, option: str, allowed, default) -> tuple[str, ...]:
    if not text:
        return tuple(default)
    values = tuple(x.strip() for x in text.split(","))
    unknown = [v for v in values if v not in allowed]
    if unknown:
        raise TestbedError(f"{option}: unknown {unknown}; expected some of: {', '.join(allowed)}")
    return values
