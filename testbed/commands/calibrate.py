"""`testbed calibrate`: fit contact parameters to recorded cube tosses, or evaluate a parameter file.

  testbed calibrate fit [--data FILE.npz] --out DIR [--model point|hydroelastic]
        [--approximation sap|similar|lagged|tamsi] [--split FRACTION|none] [--seed N]
        [--workers N] [--budget N] [--time-step H] [--free NAMES] [--start PARAMS.yaml]
  testbed calibrate evaluate [--data FILE.npz] --params PARAMS.yaml --out DIR [--workers N]
        [--initial-state first-frame|flight-fit]

--data defaults to the tosses shipped in the package (testbed/calibration/cube_tosses/even.npz).
fit writes DIR/params.yaml (a scene fragment), metrics.json (train and held-out errors),
per_toss.csv, report.md and plots; evaluate writes DIR/metrics.json (position_error_mean,
position_error_median, rotation_error_mean_deg, n_trajectories, wall_s), per_toss.csv and
plots. Output directories appear only when complete (records.atomic_directory).
Parallel rollouts run in a local process pool (--workers); there is no Ray executor: a
full evaluation takes seconds per core, far below what a cluster would pay back.
"""

from __future__ import annotations

import argparse
from pathlib import Path

# testbed.calibration.data.SHIPPED_TOSSES (BSD-3-Clause, DAIRLab), spelled out so the CLI's start imports no numpy
SHIPPED_TOSSES = Path(__file__).resolve().parents[1] / "calibration" / "cube_tosses" / "even.npz"

NAME = "calibrate"
HELP = "fit contact parameters to real cube tosses, or evaluate a parameter file on them"


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}")
    return value


def add_arguments(parser) -> None:
    sub = parser.add_subparsers(dest="calibrate_command", required=True, metavar="{fit,evaluate}")
    fit = sub.add_parser("fit", help="fit contact parameters on a training split; report the held-out error")
    fit.add_argument("--data", default=str(SHIPPED_TOSSES), help="toss file (.npz: states, offsets, toss_id, dt; "
                                                                "default: the shipped even-numbered DAIR Lab tosses)")
    fit.add_argument("--out", required=True, help="output directory")
    fit.add_argument("--model", default="point", choices=("point", "hydroelastic"))
    fit.add_argument("--approximation", default="sap", choices=("sap", "similar", "lagged", "tamsi"))
    fit.add_argument("--split", default="0.5", help="held-out fraction of tosses (duplicates kept together), or 'none' (default 0.5)")
    fit.add_argument("--seed", type=int, default=0, help="seed of the split (default 0)")
    fit.add_argument("--workers", type=_positive_int, default=2, help="rollout processes (default 2)")
    fit.add_argument("--budget", type=_positive_int, default=150, help="parameter sets to try at most (default 150)")
    fit.add_argument("--time-step", type=float, default=5e-4, help="largest plant step [s]; rounded so frames fall on steps (default 5e-4)")
    fit.add_argument("--free", help="comma-separated parameters to vary (default: mu, stiffness or modulus, dissipation; "
                                    "also table_height, corner_spheres, hydroelastic_margin)")
    fit.add_argument("--start", help="a params.yaml to start from (default: built-in start values)")
    ev = sub.add_parser("evaluate", help="roll out every toss of a file with given parameters")
    ev.add_argument("--data", default=str(SHIPPED_TOSSES), help="toss file (.npz; default: the shipped tosses)")
    ev.add_argument("--params", required=True, help="params.yaml written by `calibrate fit` (a scene fragment)")
    ev.add_argument("--out", required=True, help="output directory")
    ev.add_argument("--workers", type=_positive_int, default=2, help="rollout processes (default 2)")
    ev.add_argument("--initial-state", default="first-frame", choices=("first-frame", "flight-fit"),
                    help="rollouts start from the recorded first frame (the published metric, default) or from "
                         "a fit to the pre-impact free-flight frames (a diagnostic, reported separately)")


def run(args) -> int:
    from testbed.calibration import workflow

    if args.calibrate_command == "fit":
        return workflow.fit_command(args)
    return workflow.evaluate_command(args)
