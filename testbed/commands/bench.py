"""`testbed bench PREDICTOR [PREDICTOR ...]`: judge predictors side by side (testbed.bench)."""

from __future__ import annotations

from pathlib import Path

from learned_contact import sources
from testbed.commands import timestamp

NAME = "bench"
HELP = ("judge one or more contact predictors side by side (accuracy, scenes, closed loop, cost) -> bench.json; "
        "exit 0 when every model you named that the testbed did not ship (or, naming only shipped ones, every one) "
        "is good enough, 1 when one is not, 2 on bad input")


def add_arguments(parser) -> None:
    parser.add_argument("predictors", nargs="*", default=list(sources.SHIPPED_NAMES),
                        help=f"each one of: {sources.HELP} (default: improved paper)")
    parser.add_argument("--quick", action="store_true",
                        help="two_stack open loop and three closed-loop scenes (about a minute); accuracy and cost as in full")
    parser.add_argument("--out", help="output directory (default reports/bench/<time>)")
    parser.add_argument("--workers", type=int, default=2, help="processes labelling the held-out poses (default 2)")
    parser.add_argument("--seed", type=int, default=0, help="held-out seed (the gates use 0)")
    parser.add_argument("--no-references", action="store_true",
                        help="judge only the models named (default: the shipped predictors not named run beside them "
                             "as reference rows)")


def run(args) -> int:
    from testbed.bench import bench
    from testbed.errors import TestbedError

    if args.workers < 1:
        raise TestbedError(f"--workers: expected at least 1, got {args.workers}")
    out = Path(args.out) if args.out else Path("reports") / "bench" / timestamp()
    data = bench(args.predictors or list(sources.SHIPPED_NAMES), quick=args.quick, out_dir=out, seed=args.seed,
                 workers=args.workers, references=not args.no_references)
    from testbed.bench.report import headline

    good, lines = headline(data)
    for line in lines:
        print(line)
    print("leaderboard: " + ", ".join(f"{rank}. {data['predictors'][s]['label']}" for rank, s in enumerate(data["leaderboard"], 1)))
    print(f"report: {out / 'index.html'}")
    return 0 if good else 1
