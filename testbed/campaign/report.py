"""A campaign's files: campaign.json (the settings, the verdict's figures and every sample's record),
campaign.md and index.html (the verdict first: agreement with its 95 % interval, then the outcome table,
the error distribution, the worst samples), and worst/<index>.yaml, a scene file that reproduces each
worst sample (`testbed compare worst/<index>.yaml` replays it against the truth, with Meshcat)."""

from __future__ import annotations

import json
from pathlib import Path

from testbed.campaign.family import Family, checked_sample
from testbed.document import Bullets, Section, Text, Verdict, table, to_html, to_markdown
from testbed.records import json_default, write_atomic
from testbed.scenario import dump_scenario


def short(path: str) -> str:
    """A field path as a table shows it: containers[3].X_WC.rotation.deg[0] -> [3].rpy[0]."""
    return (path.replace("containers[", "[").replace(".X_WC.translation", ".p").replace(".X_WC.rotation.deg", ".rpy")
            .replace("effects.", ""))


def _mm(x) -> str:
    return "-" if x is None else f"{1e3 * x:.3g} mm"


def sections(summary: dict, records: list[dict], settings: dict) -> list[Section]:
    low, high = summary["interval_95"]
    head = (f"{settings['candidate_label']} agrees with the truth's outcome in {summary['agree']} of {summary['judged']} "
            f"samples of {settings['family']} ({100 * summary['agreement']:.0f} %, 95 % interval {100 * low:.0f}-"
            f"{100 * high:.0f} %; a PASS needs the lower end at {100 * summary['required_lower']:.0f} %)"
            if summary["judged"] else f"no sample of {settings['family']} could be judged")
    lines = [f"{summary['refused']} samples refused as scene files (never simulated), {summary['errors']} failed to run"]
    if summary["verdict"] == "UNDECIDED":
        lines.insert(0, f"UNDECIDED: every judged sample agrees, but {summary['judged']} are too few to put the lower end at "
                        f"{100 * summary['required_lower']:.0f} %; run at least {summary['needed']}")
    lines.append(f"well-posed samples (the truth's 1 mm perturbed twin ends within 5 mm): {summary['well_posed']}; "
                 f"their final error median {_mm(summary['final_error_median_m'])}, p95 {_mm(summary['final_error_p95_m'])}")
    by_index = {r["index"]: r for r in records}
    worst = [by_index[i] for i in summary["worst"]]
    rows = [(r["index"], "yes" if r["agree"] else "NO", f"{r['classes']['truth']} / {r['classes']['candidate']}",
             _mm(r["final_error_m"]), _mm(r["truth_spread_m"]), "yes" if r["well_posed"] else "no",
             ", ".join(f"{short(k)}={v:.4g}" if isinstance(v, float) else f"{short(k)}={v}" for k, v in r["values"].items()))
            for r in worst]
    return [Section(None, [Verdict(summary["verdict"] == "PASS", head), Bullets(tuple(lines))], order=0),
            Section("Outcomes (truth -> candidate)", [table(["truth -> candidate", "samples"], summary["outcomes"].items())]),
            Section("The worst samples", [Text("Replay one against the truth: testbed compare worst/<index>.yaml."),
                                          table(["sample", "agrees", "truth / candidate", "final error",
                                                 "truth's own spread", "well posed", "drawn"], rows)])]


def write(out: Path, family: Family, summary: dict, records: list[dict], settings: dict) -> None:
    """The campaign's files in `out` (samples/ is the executor's, already there)."""
    out.mkdir(parents=True, exist_ok=True)
    write_atomic(out / "campaign.json", json.dumps({"settings": settings, "summary": summary, "samples": records},
                                                   indent=1, default=json_default))
    parts = sections(summary, records, settings)
    title = f"Campaign: {family.name}"
    write_atomic(out / "campaign.md", to_markdown(title, parts))
    write_atomic(out / "index.html", to_html(title, parts))
    (out / "worst").mkdir(exist_ok=True)
    by_index = {r["index"]: r for r in records}
    for i in summary["worst"]:
        scenario, _ = checked_sample(family, by_index[i])
        if scenario is not None:
            write_atomic(out / "worst" / f"{i:04d}.yaml", dump_scenario(scenario))
