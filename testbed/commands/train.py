"""`testbed train`: train the learned predictors from a seed (needs the `train` extra)."""

from __future__ import annotations

from pathlib import Path

from testbed.commands import timestamp

NAME = "train"
HELP = "train the learned predictors from a seed (reproduces learned_contact/shipped)"


def add_arguments(parser) -> None:
    parser.add_argument("--out", help="output directory (default reports/train-<time>)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the shipped model: 0")
    parser.add_argument("--quiet", action="store_true", help="no progress bars")
    parser.add_argument("--rescore", action="store_true",
                        help="no training: re-score the shipped weights with today's inference code on the default "
                             "run's own labelled sets (metrics.json, report.md into --out, default "
                             "learned_contact/shipped); needs Drake, not torch")


def run(args) -> int:
    if args.rescore:
        from learned_contact.training.train import rescore_shipped

        metrics = rescore_shipped(args.out, progress=not args.quiet)
        stacking = metrics["improved"]["external/stacking"]["point_m"]
        print(f"re-scored: external stacking point median {stacking['median'] * 1e3:.3f} mm, "
              f"p95 {stacking['p95'] * 1e3:.2f} mm -> {args.out or 'learned_contact/shipped'}")
        return 0
    try:
        import torch  # noqa: F401
    except ImportError:
        from testbed.errors import OptionalDependencyError

        raise OptionalDependencyError("torch", "testbed train", "train") from None
    from learned_contact.training.train import train_default

    out = Path(args.out) if args.out else Path("reports") / f"train-{timestamp()}"
    metrics = train_default(out, seed=args.seed, progress=not args.quiet)
    print((out / "report.md").read_text())
    print(f"trained model: {out} (wall time {metrics['wall_time_s']['total']:.0f} s); "
          f"to ship it: copy its files into learned_contact/shipped/")
    return 0
