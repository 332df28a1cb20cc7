"""The two calibration workflows behind `testbed calibrate fit` / `evaluate` (arguments in, files out)."""

from __future__ import annotations

import dataclasses
import math
import sys
import time
from pathlib import Path

from testbed.calibration import report
from testbed.calibration.data import load_tosses
from testbed.calibration.evaluate import RolloutPool, summarize
from testbed.calibration.fit import fit, free_parameters, parse_free
from testbed.calibration.params_file import from_fragment, to_fragment
from testbed.calibration.rollout import CubeTossParams, TossSimulator
from testbed.calibration.split import parse_split, train_test_split
from testbed.errors import TestbedError
from testbed.records import atomic_directory

# Start values: the basin found by scans of this data (friction ~0.185 is sharp; see README).
START = {"point": dict(mu=0.185, point_contact_stiffness=1.0e6, relaxation_time=1.0e-3, corner_spheres=1.0e-4),
         "hydroelastic": dict(mu=0.185, hydroelastic_modulus=1.0e8, relaxation_time=1.0e-3)}


def _frame_step(requested: float, frame_dt: float) -> float:
    if not (math.isfinite(requested) and requested > 0):
        raise TestbedError(f"--time-step: expected a positive step [s], got {requested}")
    return frame_dt / math.ceil(frame_dt / requested - 1e-9)


def fit_command(args) -> int:
    data = load_tosses(args.data)
    test_fraction = parse_split(args.split)
    if args.start:
        base = from_fragment(args.start)
        if (base.model, base.approximation) != (args.model, args.approximation):
            raise TestbedError(f"--start: {args.start} is for {base.model}/{base.approximation}, not {args.model}/{args.approximation}")
    else:
        base = CubeTossParams(model=args.model, approximation=args.approximation, **START[args.model])
    base = dataclasses.replace(base, time_step=_frame_step(args.time_step, data.dt))
    free = parse_free(args.free, base.model, base.approximation) if args.free else free_parameters(base.model, base.approximation)
    train, test = train_test_split(data.tosses, test_fraction, args.seed) if test_fraction else (list(range(len(data.tosses))), [])
    start = time.perf_counter()

    def progress(n, error, params):
        values = " ".join(f"{p.name}={getattr(params, p.name):.4g}" for p in free)
        print(f"[calibrate] evaluation {n}/{args.budget}: {100 * error:.2f}% ({values})", file=sys.stderr, flush=True)

    with RolloutPool(data, args.workers) as pool:
        result = fit(pool, base, train, free=free, max_evaluations=args.budget, progress=progress)
        train_results = pool.evaluate(result.params, train)
        test_results = pool.evaluate(result.params, test) if test else []
    wall = time.perf_counter() - start
    rows = {"train": summarize(train_results, wall)}
    if test_results:
        rows["test"] = summarize(test_results, wall)
    split = {data.tosses[i].toss_id: "train" for i in train} | {data.tosses[i].toss_id: "test" for i in test}
    metrics = dict(rows.get("test", rows["train"]))  # headline: the held-out figures when there are any
    metrics.update(train=rows["train"], test=rows.get("test"), wall_s=wall, n_evaluations=result.n_evaluations,
                   data=str(args.data), split=args.split, seed=args.seed, workers=args.workers,
                   free_parameters=[p.name for p in free], start=args.start,
                   params=dataclasses.asdict(result.params))
    comment = (f"Fitted by `testbed calibrate fit` on {len(train)} tosses of {Path(args.data).name} "
               f"(split {args.split}, seed {args.seed}).\n"
               + "".join(f"{name}: position error mean {100 * m['position_error_mean']:.2f}% of cube width "
                         f"({m['n_trajectories']} tosses)\n" for name, m in rows.items())
               + "Same contact values on cube and table: Drake's pair values are mu, stiffness / 2.")
    with atomic_directory(args.out) as tmp:
        (tmp / "params.yaml").write_text(to_fragment(result.params, comment))
        report.write_metrics(tmp, metrics)
        report.write_per_toss(tmp, train_results + test_results, split)
        report.plot_errors(tmp, train_results + test_results, split)
        report.plot_trajectories(tmp, data, test_results or train_results, TossSimulator(result.params, data.dt))
        (tmp / "report.md").write_text(report.markdown(f"Cube-toss fit: {base.model} contact, {base.approximation}", rows,
                                                       dataclasses.asdict(result.params)))
    for name, m in rows.items():
        print(f"{name}: position error mean {100 * m['position_error_mean']:.2f}%, median "
              f"{100 * m['position_error_median']:.2f}% of cube width ({m['n_trajectories']} tosses)")
    print(f"wrote {args.out} ({result.n_evaluations} evaluations, {wall:.0f} s)")
    return 0


def evaluate_command(args) -> int:
    params = from_fragment(args.params)
    start = time.perf_counter()
    data = load_tosses(args.data)
    initial = getattr(args, "initial_state", "first-frame")
    with RolloutPool(data, args.workers) as pool:
        results = pool.evaluate(params, initial=initial)
    metrics = summarize(results, time.perf_counter() - start)
    metrics.update(data=str(args.data), params_file=str(args.params), workers=args.workers, initial_state=initial,
                   params=dataclasses.asdict(params))
    with atomic_directory(args.out) as tmp:
        report.write_metrics(tmp, metrics)
        report.write_per_toss(tmp, results)
        report.plot_errors(tmp, results)
        report.plot_trajectories(tmp, data, results, TossSimulator(params, data.dt), initial=initial)
        notes = "" if initial == "first-frame" else (
            f"Initial state: {initial} (fitted to the pre-impact frames), NOT the published first-frame protocol.")
        (tmp / "report.md").write_text(report.markdown(f"Cube-toss evaluation: {Path(args.params).name}", {"all": metrics},
                                                       dataclasses.asdict(params), notes))
    print(f"[initial state: {initial}] " * (initial != "first-frame")
          + f"position error mean {100 * metrics['position_error_mean']:.2f}%, "
          f"median {100 * metrics['position_error_median']:.2f}% of cube width "
          f"over {metrics['n_trajectories']} tosses ({metrics['wall_s']:.1f} s); wrote {args.out}")
    return 0
