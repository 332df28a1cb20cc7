"""`testbed run-all`: every shipped scene under each contact model; a summary report."""

from __future__ import annotations

from pathlib import Path

from testbed.commands import timestamp

NAME = "run-all"
HELP = "run every shipped scene under each contact model; write a summary report"


def add_arguments(parser) -> None:
    parser.add_argument("--out", help="report directory (default reports/run-all-<time>)")
    parser.add_argument("--duration", type=float, help="override every scene's simulated time [s]")
    parser.add_argument("--models", nargs="+", default=["hydroelastic", "point"],
                        help="contact models to run each scene with (default: hydroelastic point)")
    parser.add_argument("--quiet", action="store_true", help="no progress bars")


def run(args) -> int:
    from testbed.batch import run_all

    out = Path(args.out) if args.out else Path("reports") / f"run-all-{timestamp()}"
    report = run_all(out, duration=args.duration, models=args.models, progress=not args.quiet)
    print(report)
    print(f"report: {out}")
    return 0
