"""`testbed study NAME`: one study on its own, written to a directory.

A dispatcher over the registered studies (testbed/studies/: one package each, registered with
testbed.studies.register): the choices of NAME and each study's own options (one group per
study in `testbed study --help`) come from the registry; the options every study shares are
this command's (testbed.studies.base.COMMON).
"""

from __future__ import annotations

from pathlib import Path

from testbed.commands import timestamp
from testbed.studies import studies

NAME = "study"
HELP = ("one study on its own, written to a directory: sim, query, stability, defaults, scale, truth or any other "
        "registered study (`testbed study --help` lists each with its options)")


def add_arguments(parser) -> None:
    found = studies()
    parser.add_argument("which", choices=list(found), metavar="which",
                        help="the study: " + "; ".join(f"{s.name} ({s.help})" for s in found.values()))
    parser.add_argument("--out", help="output directory (default reports/study-<which>-<time>)")
    parser.add_argument("--quick", action="store_true", help="a small grid (about a minute)")
    parser.add_argument("--quiet", action="store_true", help="no progress bars")
    parser.add_argument("--workers", type=int, default=2, help="processes of the defaults sweep and of scale's --executor local (default 2)")
    parser.add_argument("--duration", type=float,
                        help="[s] simulated: scale, each run's timed window (default 0.1; --quick 0.04); truth, replaces every scene's")
    for s in found.values():
        s.add_arguments(parser.add_argument_group(f"{s.name} study ({s.help})"))


def run(args) -> int:
    """Configures the study (bad input: a TestbedError, exit 2, nothing written), runs it, writes
    its report and prints its summary."""
    from testbed.validation.executors import map_calls  # validate's executors, for a study's parts

    chosen = studies()[args.which]
    out = Path(args.out) if args.out else Path("reports") / f"study-{args.which}-{timestamp()}"
    config = chosen.configure(args)
    result = chosen.run(config, out, map_calls=map_calls)
    chosen.report(result, out)
    for line in chosen.summary(result):
        print(line)
    print(f"study output: {out}")
    return 0
