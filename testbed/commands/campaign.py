"""`testbed campaign FAMILY.yaml`: a scene family sampled, each sample's truth and candidate from the
same start, the outcome agreement with its 95 % interval (testbed/campaign/); with --search, the family's
worst case searched for instead (the cross-entropy method: testbed/campaign/search.py)."""

from __future__ import annotations

from pathlib import Path

from testbed.commands import timestamp
from testbed.errors import ScenarioError, TestbedError, one_of

NAME = "campaign"
HELP = "sample a scene family, run the truth and a candidate on each sample, judge the outcome agreement"
CANDIDATE_HELP = ("the learned loop's predictor (improved, paper, a weights or ONNX file, module:attribute), "
                  "or 'point' for Drake point contact (default: improved)")
DEFAULT_BUDGET = 24  # sample runs a --search spends by default (a campaign's default samples on corner_drop)
MAX_RUNS = 100_000  # --samples, --budget


def add_arguments(parser) -> None:
    parser.add_argument("family", help="a family file (a scene plus vary:), or a shipped family's name")
    parser.add_argument("--samples", type=int, help="samples (default: the family's, else 32)")
    parser.add_argument("--predictor", default="improved", help=CANDIDATE_HELP)
    parser.add_argument("--seed", type=int, default=0, help="the sample sequence's (or the search's) seed (default 0)")
    parser.add_argument("--duration", type=float, help="simulated time per sample [s] (default: the family's)")
    parser.add_argument("--out", help="output directory (default reports/campaign/<family>-<time>); an existing "
                                      "one resumes: finished samples are kept")
    parser.add_argument("--executor", default="local", help="local (a process pool) or ray")
    parser.add_argument("--workers", type=int, default=2, help="local worker processes (default 2)")
    parser.add_argument("--ray-address", help="a Ray cluster's address (--executor ray; default: a local one)")
    parser.add_argument("--search", action="store_true",
                        help="search for the worst case instead of sampling: the cross-entropy method over the family's "
                             "vary: fields, maximising the candidate's final position error against the truth")
    parser.add_argument("--budget", type=int, help=f"--search: the sample runs it may spend (default {DEFAULT_BUDGET})")
    parser.add_argument("--population", type=int, help="--search: runs per generation (default: about the budget's square root)")
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


def _check_search_options(args) -> None:
    """--budget and --population only with --search, and in range; --samples not with it."""
    if not args.search:
        for flag, value in (("--budget", args.budget), ("--population", args.population)):
            if value is not None:
                raise TestbedError(f"{flag}: only with --search (a campaign without it runs --samples samples)")
        return
    if args.samples is not None:
        raise TestbedError("--samples: not with --search (the search spends --budget runs)")
    if args.budget is not None and not 1 <= args.budget <= MAX_RUNS:
        raise TestbedError(f"--budget: expected 1 to {MAX_RUNS} sample runs, got {args.budget}")
    if args.population is not None and not 1 <= args.population <= (args.budget or DEFAULT_BUDGET):
        raise TestbedError(f"--population: expected 1 to the budget ({args.budget or DEFAULT_BUDGET}) runs per generation, "
                           f"got {args.population}")


def run(args) -> int:
    from testbed.campaign import report, search
    from testbed.campaign.family import load_family
    from testbed.campaign.runs import SampleRuns, run_search
    from testbed.campaign.verdict import summarise
    from testbed.validation.executors import map_calls  # validate's executors, handed in (a layer above)

    _check_search_options(args)
    if args.seed < 0:
        raise TestbedError(f"--seed: expected a non-negative integer, got {args.seed}")
    path = family_path(args.family)
    try:
        family = load_family(path)
    except ScenarioError as e:
        if args.search and e.field == "vary":
            raise TestbedError(f"--search: {e} (the search varies a family's vary: fields)") from None
        raise
    n = args.samples if args.samples is not None else family.samples
    if not 1 <= n <= MAX_RUNS:
        raise TestbedError(f"--samples: expected 1 to {MAX_RUNS}, got {n}")
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
    tag = "-search" if args.search else ""
    out = Path(args.out) if args.out else Path("reports") / "campaign" / f"{family.name}{tag}-{timestamp()}"
    settings = {"family": family.name, "source": str(path), "seed": args.seed, "duration_s": duration,
                "candidate": args.predictor,
                "candidate_label": "Drake point contact" if args.predictor == "point" else f"the learned loop ({args.predictor})",
                "varied": {v.path: {v.kind: list(v.args)} for v in family.varied}}
    total = (args.budget or DEFAULT_BUDGET) if args.search else n
    runs = SampleRuns(out / ("search" if args.search else "samples"), path, args.predictor, duration, total=total,
                      what="run" if args.search else "sample", executor=args.executor, workers=args.workers,
                      address=args.ray_address, quiet=args.quiet, map_calls=map_calls)
    if args.search:  # the worst case searched for (testbed/campaign/search.py)
        population = args.population or search.default_population(total)
        settings["search"] = {"budget": total, "population": population, "objective": "final_error_m",
                              "elite_fraction": search.ELITE_FRACTION, "min_elite": search.MIN_ELITE,
                              "smoothing": search.SMOOTHING}
        if not args.quiet:
            print(f"search {family.name}: {total} runs in generations of {population}, {settings['candidate_label']}, "
                  f"{duration:g} s each; maximising the final position error against the truth", flush=True)
        records, summary, found = run_search(runs, family, total, population, args.seed)
        report.write(out, family, summary, records, settings, search=found)
        top = {r["index"]: r for r in records}.get(found["worst"][0]) if found["worst"] else None
        head = (f"worst final error {report.mm(top['final_error_m'])} (run {top['index']}, generation "
                f"{top['generation']}, {'agrees' if top['agree'] else 'DISAGREES'})" if top else "nothing judged")
        print(f"search: {summary['verdict']}: {head}; {summary['disagree']} of {summary['judged']} judged runs disagree, "
              f"{summary['refused']} refused, {summary['errors']} failed, {runs.reused} found done in {runs.folder}; "
              f"report {out / 'index.html'}")
        return 3 if summary["verdict"] == "FAIL" else 0
    samples = family.sample(n, args.seed)
    settings["samples"] = n
    if not args.quiet:
        print(f"campaign {family.name}: {n} samples ({sum(runs.saved(s) is not None for s in samples)} already done), "
              f"{settings['candidate_label']}, {duration:g} s each", flush=True)
    records = runs(samples)
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
