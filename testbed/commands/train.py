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


def run(args) -> int:
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
