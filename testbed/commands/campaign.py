"""`testbed campaign FAMILY.yaml`: a scene family sampled, each sample's truth and candidate from the
same start, the outcome agreement with its 95 % interval (testbed/campaign/)."""

from __future__ import annotations

import json
from pathlib import Path

from testbed.commands import timestamp
from testbed.errors import TestbedError, one_of

NAME = "campaign"
HELP = "sample a scene family, run the truth and a candidate on each sample, judge the outcome agreement"
CANDIDATE_HELP = ("the learned loop's predictor (improved, paper, a weights or ONNX file, module:attribute), "
                  "or 'point' for Drake point contact (default: improved)")


def add_arguments(parser) -> None:
    parser.add_argument("family", help="a family file (a scene plus vary:), or a shipped family's name")
    parser.add_argument("--samples", type=int, help="samples (default: the family's, else 32)")
    parser.add_argument("--predictor", default="improved", help=CANDIDATE_HELP)
    parser.add_argument("--seed", type=int, default=0, help="the sample sequence's seed (default 0)")
    parser.add_argument("--duration", type=float, help="simulated time per sample [s] (default: the family's)")
    parser.add_argument("--out", help="output directory (default reports/campaign/<family>-<time>); an existing "
                                      "one resumes: finished samples are kept")
    parser.add_argument("--executor", default="local", help="local (a process pool) or ray")
    parser.add_argument("--workers", type=int, default=2, help="local worker processes (default 2)")
    parser.add_argument("--ray-address", help="a Ray cluster's address (--executor ray; default: a local one)")
    parser.add_argument("--quiet", action="store_true", help="no progress lines")


def family_path(name: str) -> Path:
    """A family file, or a shipped family's name (testbed/families/<name>.yaml)."""
    path = Path(name)
    if path.suffix in (".yaml", ".yml") or path.exists():
        return path
    shipped = Path(__file__).resolve().parents[1] / "families" / f"{name}.yaml"
    if not shipped.exists():
        names = sorted(p.stem for p in shipped.parent.glob("*.yaml"))
        raise TestbedError(f"family {name!r}: no such file or shipped family; {one_of(name, names)}")
    return shipped


def run(args) -> int:
    from testbed.campaign import report
    from testbed.campaign.family import load_family
    from testbed.campaign.sample import run_sample
    from testbed.campaign.verdict import summarise
    from testbed.records import json_default, write_atomic
    from testbed.safe_files import load_json
    from testbed.validation.executors import map_calls

    path = family_path(args.family)
    family = load_family(path)
    n = args.samples if args.samples is not None else family.samples
    if not 1 <= n <= 100_000:
        raise TestbedError(f"--samples: expected 1 to 100000, got {n}")
    if args.duration is not None and not args.duration > 0:
        raise TestbedError(f"--duration: expected a positive number of seconds, got {args.duration}")
    if args.workers < 1:
        raise TestbedError(f"--workers: expected at least 1, got {args.workers}")
    duration = args.duration or family.duration
    if args.predictor != "point":  # a bad predictor is refused before anything runs
        from learned_contact.sources import load_predictor

        try:
            load_predictor(args.predictor)
        except Exception as e:  # noqa: BLE001 - the loaders' one-line errors
            raise TestbedError(f"--predictor: {str(e).splitlines()[0]}") from None
    out = Path(args.out) if args.out else Path("reports") / "campaign" / f"{family.name}-{timestamp()}"
    folder = out / "samples"
    folder.mkdir(parents=True, exist_ok=True)
    samples = family.sample(n, args.seed)
    settings = {"family": family.name, "source": str(path), "samples": n, "seed": args.seed, "duration_s": duration,
                "candidate": args.predictor,
                "candidate_label": "Drake point contact" if args.predictor == "point" else f"the learned loop ({args.predictor})",
                "varied": {v.path: {v.kind: list(v.args)} for v in family.varied}}

    def saved(i: int):
        f = folder / f"{i:05d}.json"
        if not f.exists():
            return None
        try:
            record = load_json(f, 2**20, "campaign sample record")
        except Exception:  # noqa: BLE001 - a torn record is recomputed
            return None
        same = record.get("overrides") == samples[i]["overrides"] and record.get("candidate") == args.predictor
        return record if same else None

    records = {i: r for i in range(n) if (r := saved(i)) is not None}
    todo = [{"family": str(path), "sample": samples[i], "candidate": args.predictor, "duration": duration}
            for i in range(n) if i not in records]
    if not args.quiet:
        print(f"campaign {family.name}: {n} samples ({len(records)} already done), {settings['candidate_label']}, "
              f"{duration:g} s each", flush=True)

    def done(record: dict) -> None:
        record["candidate"] = args.predictor
        write_atomic(folder / f"{record['index']:05d}.json", json.dumps(record, indent=1, default=json_default))
        records[record["index"]] = record
        if not args.quiet:
            what = record["status"] if record["status"] != "ok" else ("agrees" if record["agree"] else "DISAGREES")
            print(f"  sample {record['index']}: {what} ({len(records)} of {n})", flush=True)

    map_calls(run_sample, todo, done, executor=args.executor, workers=args.workers, address=args.ray_address)
    ordered = [records[i] for i in range(n)]
    summary = summarise(ordered)
    report.write(out, family, summary, ordered, settings)
    low, high = summary["interval_95"]
    if summary["verdict"] == "UNDECIDED":
        print(f"  every judged sample agrees, but {summary['judged']} cannot put the lower end at "
              f"{summary['required_lower']:.2f}: run at least {summary['needed']} (--samples)")
    print(f"verdict: {summary['verdict']}: agreement {summary['agree']}/{summary['judged']} "
          f"(95 % interval {low:.2f}-{high:.2f}, needs the lower end >= {summary['required_lower']:.2f}); "
          f"{summary['refused']} refused, {summary['errors']} failed; report {out / 'index.html'}")
    return 0 if summary["verdict"] == "PASS" else 3
