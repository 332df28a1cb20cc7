"""`testbed validate`: run a validation suite, write reports/<time>/ (exit 3 if a gate fails)."""

from __future__ import annotations

NAME = "validate"
HELP = "run a validation suite and write reports/<time>/ (exit 3 if a gate fails)"


def add_arguments(parser) -> None:
    parser.add_argument("--suite", default="default", help="default (about 10 min on 2 cores), full, or smoke (seconds)")
    parser.add_argument("--workers", type=int, default=2, help="worker processes (default 2)")
    parser.add_argument("--executor", default="local", help="local (process pool) or ray")
    parser.add_argument("--address", help="Ray cluster address (with --executor ray); default: start a local Ray")
    parser.add_argument("--resume", metavar="RUN_DIR", help="finish an interrupted run: compute only its missing cases")
    parser.add_argument("--out", default="reports", metavar="DIR",
                        help="where the run directory <time>/ is made (default reports)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.add_argument("--predictor", action="append", default=[], metavar="P",
                        help="add a predictor to the learned, closed-loop and query sections (repeatable; reported "
                             "beside the shipped ones, not gated): an ONNX model, a weights .npz or module:attribute")


def run(args) -> int:
    from testbed.validation import validate

    run_dir, metrics = validate(suite_name=args.suite, workers=args.workers, executor=args.executor,
                                address=args.address, resume=args.resume, out_root=args.out, progress=not args.quiet,
                                predictors=args.predictor)
    print((run_dir / "summary.md").read_text())
    print(f"report: {run_dir / 'index.html'}")
    return 0 if metrics["passed"] else 3
