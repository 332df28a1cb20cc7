"""A campaign's files: campaign.json (the settings, the verdict's figures and every sample's record),
campaign.md and index.html (the verdict first: agreement with its 95 % interval, then the outcome table,
the error distribution, the worst samples), and worst/<index>.yaml, a scene file that reproduces each
worst sample, its drawn values and the duration it was judged over (`testbed compare worst/<index>.yaml`
replays it against the truth, with Meshcat).
A worst-case search (--search) writes the same files, its section in place of the agreement verdict (the
worst error found, the history per generation, the worst cases), its worst cases as worst/<index>.yaml,
and search.json (the settings, the history, the worst cases)."""

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


def mm(x) -> str:
    """A length [m] as a table shows it, in mm (None: -)."""
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
                 f"their final error median {mm(summary['final_error_median_m'])}, p95 {mm(summary['final_error_p95_m'])}")
    rows = _worst_rows(records, summary["worst"])
    return [Section(None, [Verdict(summary["verdict"] == "PASS", head), Bullets(tuple(lines))], order=0),
            Section("Outcomes (truth -> candidate)", [table(["truth -> candidate", "samples"], summary["outcomes"].items())]),
            Section("The worst samples", [Text("Replay one against the truth: testbed compare worst/<index>.yaml."),
                                          table(["sample", "agrees", "truth / candidate", "final error",
                                                 "truth's own spread", "well posed", "drawn"], rows)])]


def _drawn(values: dict) -> str:
    return ", ".join(f"{short(k)}={v:.4g}" if isinstance(v, float) else f"{short(k)}={v}" for k, v in values.items())


def _worst_rows(records: list[dict], indices: list[int]) -> list[tuple]:
    """The worst samples' table rows: sample, agrees, classes, final error, the truth's spread, well posed, drawn."""
    by_index = {r["index"]: r for r in records}
    return [(r["index"], "yes" if r["agree"] else "NO", f"{r['classes']['truth']} / {r['classes']['candidate']}",
             mm(r["final_error_m"]), mm(r["truth_spread_m"]), "yes" if r["well_posed"] else "no", _drawn(r["values"]))
            for r in (by_index[i] for i in indices)]


def search_sections(summary: dict, records: list[dict], settings: dict, found: dict) -> list[Section]:
    """A worst-case search's report: the worst error found first, the history per generation, the worst cases."""
    by_index = {r["index"]: r for r in records}
    plan = settings["search"]
    what = (f"the search ({plan['budget']} runs, generations of {plan['population']}, the cross-entropy method "
            f"maximising the final position error against the truth)")
    if found["worst"]:
        top = by_index[found["worst"][0]]
        head = (f"{settings['candidate_label']} on {settings['family']}: worst final error {mm(top['final_error_m'])} "
                f"(run {top['index']}, generation {top['generation']}, truth {top['classes']['truth']} / candidate "
                f"{top['classes']['candidate']}, {'agrees' if top['agree'] else 'DISAGREES'}) found by {what}")
    else:
        head = f"no run of {what} on {settings['family']} could be judged"
    lines = (f"{summary['disagree']} of {summary['judged']} judged runs disagree with the truth; {summary['refused']} "
             f"refused as scene files (never simulated), {summary['errors']} failed to run",
             "the runs were chosen to make the candidate fail: their agreement is no estimate of its rate "
             "(a campaign without --search gives that)")
    history = [(h["generation"], f"{h['runs'][0]}-{h['runs'][1]}", mm(h["best"]), mm(h["best_so_far"]), mm(h["elite_mean"]))
               for h in found["history"]]
    verdict = Verdict(False, head) if summary["verdict"] == "FAIL" else Text(f"{summary['verdict']}: {head}")  # not a PASS
    return [Section(None, [verdict, Bullets(lines)], order=0),
            Section("Search history", [table(["generation", "runs", "worst of the generation", "worst so far",
                                              "elite mean"], history)]),
            Section("The worst cases found", [Text("Replay one against the truth: testbed compare worst/<index>.yaml."),
                                              table(["run", "agrees", "truth / candidate", "final error",
                                                     "truth's own spread", "well posed", "drawn"],
                                                    _worst_rows(records, found["worst"]))]),
            Section("Outcomes (truth -> candidate)", [table(["truth -> candidate", "runs"], summary["outcomes"].items())])]


def write_scenes(folder: Path, family: Family, records: list[dict], indices: list[int], duration: float) -> list[str]:
    """A scene file per listed sample, <folder>/<index>.yaml, that reproduces it (its drawn values, and the
    duration it was judged over); the files' names."""
    folder.mkdir(exist_ok=True)
    by_index = {r["index"]: r for r in records}
    names = []
    for i in indices:
        record = by_index[i]
        scenario, _ = checked_sample(family, {**record, "overrides": [*record["overrides"], f"duration={duration!r}"]})
        if scenario is not None:
            write_atomic(folder / f"{i:04d}.yaml", dump_scenario(scenario))
            names.append(f"{folder.name}/{i:04d}.yaml")
    return names


def write(out: Path, family: Family, summary: dict, records: list[dict], settings: dict, search: dict | None = None) -> None:
    """The campaign's files in `out` (samples/ or search/ is the executor's, already there); `search`: a
    worst-case search's {"history", "worst"} (then search.json too, and its sections)."""
    out.mkdir(parents=True, exist_ok=True)
    worst = summary["worst"] if search is None else search["worst"]
    scenes = write_scenes(out / "worst", family, records, worst, float(settings["duration_s"]))
    document = {"settings": settings, "summary": summary, "samples": records}
    if search is not None:
        by_index = {r["index"]: r for r in records}
        cases = [{k: by_index[i].get(k) for k in ("index", "generation", "final_error_m", "final_angle_deg", "agree",
                                                  "well_posed", "truth_spread_m", "classes", "values")}
                 | {"scene": f"worst/{i:04d}.yaml" if f"worst/{i:04d}.yaml" in scenes else None} for i in worst]
        found = {"settings": settings, "history": search["history"], "worst": cases}
        write_atomic(out / "search.json", json.dumps(found, indent=1, default=json_default))
        document = {"settings": settings, "summary": summary, "search": found, "samples": records}
    write_atomic(out / "campaign.json", json.dumps(document, indent=1, default=json_default))
    parts = sections(summary, records, settings) if search is None else search_sections(summary, records, settings, search)
    title = f"Campaign: {family.name}" if search is None else f"Worst-case search: {family.name}"
    write_atomic(out / "campaign.md", to_markdown(title, parts))
    write_atomic(out / "index.html", to_html(title, parts))
