"""`testbed compare`'s report: report.html (one self-contained page, the plots embedded) and
report.md (the plots beside it as divergence.png and error_map.png), rendered by testbed.document
from compare.json's figures and trajectories.npz's arrays. Nothing here measures again: every
number is compare.json's (the real-time factor and the cost per step are its wall time per
simulated second, inverted and times the plant step: costs.real_time_factor, costs.us_per_step).

The first screen, above any long text: the verdict of each candidate (a PASS that holds only
within pinned known limits says so: verdict_cell), then one row per candidate and one for Drake's
truth (COLUMNS): the real-time factor and the simulated window it was measured over, the cost per
plant step [us], the final position and angle error against the truth [mm, deg], the deepest
penetration [mm], the energy raw (max over t of E(t) - E(0)) and net of the external actors' work
(the energy gate's figure: external_work.energy_figures) and that work's largest |W(t)|; then each
judged candidate's gates, the plots (report_plots.py), what the figures mean, and the files.
"""

from __future__ import annotations

import math
from pathlib import Path

from testbed.compare import report_plots
from testbed.compare.costs import breakdown_line, real_time_factor, us_per_step
from testbed.compare.metrics import joules
from testbed.compare.verdict import PASS, headline, verdict_lines
from testbed.document import Bullets, Figure, Link, Section, Text, png, table, to_html, to_markdown
from testbed.gates import KNOWN_LIMIT, is_known_limit, shown
from testbed.records import write_atomic

HTML, MARKDOWN = "report.html", "report.md"
DIVERGENCE, ERROR_MAP = "divergence.png", "error_map.png"
TRUTH = "Drake hydroelastic (the truth)"
REFERENCE = "reference"  # the truth row's verdict cell
NOT_GATED = "not gated"  # a candidate no gate judges (Drake point, an engine with its own contact)
NONE = "-"  # a figure that does not apply to the row
# (row key, column header) of the first screen's table, in order
COLUMNS = (("candidate", "candidate"), ("verdict", "verdict"), ("rtf", "real-time factor [x]"),
           ("window", "measured over t [s]"), ("us", "cost per step [us]"),
           ("pos", "final position error [mm]"), ("angle", "final angle error [deg]"),
           ("pen", "worst penetration [mm]"), ("raw", "energy raw [J]"),
           ("net", "energy net of external work [J]"), ("work", "external work max |W| [J]"))


def verdict_cell(c: dict) -> str:
    """The verdict of one candidate's figures `c` as the report writes it: compare.json's verdict,
    except a PASS with gates held only within pinned known limits ('PASS only within 2 pinned
    known limits: final position, final angle') and a candidate no gate judges (NOT_GATED)."""
    verdict = c.get("verdict")
    if verdict is None:
        return NOT_GATED + (" (DIVERGED)" if c.get("diverged") else "")
    pinned = [name.replace(KNOWN_LIMIT, "").strip() for name in c.get("gates_known_limits") or []]
    if verdict == PASS and pinned:
        return f"PASS only within {len(pinned)} pinned known limit{'s' if len(pinned) > 1 else ''}: {', '.join(pinned)}"
    return str(verdict)


def _n(value, fmt: str = ".4g", scale: float = 1.0) -> str:
    if value is None:
        return NONE
    value = float(value) * scale
    return "inf" if math.isinf(value) else "n/a" if math.isnan(value) else format(value, fmt)


def rows(f: dict) -> list[dict]:
    """The first screen's table as data: one dict per candidate of compare.json `f` (COLUMNS'
    keys; numbers in the columns' units, None where a figure does not apply), then Drake's truth."""
    h = f["time_step_s"]
    out = []
    for label, c in f["candidates"].items():
        if "wall_per_sim_s_learned" not in c:  # --no-truth: the candidate timed alone
            wall, window = c["wall_per_sim_s"], c["simulated_s"]
            out.append({"candidate": label, "verdict": str(f["verdict"]), "rtf": real_time_factor(wall),
                        "window": window, "us": us_per_step(wall, h)})
            continue
        wall = c["wall_per_sim_s_learned"]
        counted = c.get("external_work_counted", False)
        out.append({"candidate": label, "verdict": verdict_cell(c), "rtf": real_time_factor(wall),
                    "window": c["simulated_s_learned"], "us": us_per_step(wall, h),
                    "pos": c["final_position_error_max_m"] * 1e3, "angle": c["final_angle_error_max_deg"],
                    "pen": c["max_penetration_m"] * 1e3, "raw": c["energy_gain_max_J"],
                    "net": c.get("energy_created_J"), "work": c.get("external_work_max_J") if counted else None,
                    "work_known": counted})
    if "wall_per_sim_s_truth" in f:
        wall = f["wall_per_sim_s_truth"]
        out.append({"candidate": TRUTH, "verdict": REFERENCE, "rtf": real_time_factor(wall), "window": f["duration_s"],
                    "us": us_per_step(wall, h), "pen": f.get("max_penetration_truth_m", math.nan) * 1e3,
                    "raw": f.get("energy_gain_max_truth_J")})
    return out


def cells(row: dict) -> list[str]:
    """A row of rows() as the table's text, in COLUMNS' order."""
    work = joules(row.get("work")) if row.get("work_known", True) else "not known"
    return [row["candidate"], row["verdict"], _n(row.get("rtf"), ".3g"),
            NONE if row.get("window") is None else f"0-{row['window']:g}", _n(row.get("us"), ".0f" if row.get("us", 0) >= 100 else ".3g"),
            _n(row.get("pos")), _n(row.get("angle")), _n(row.get("pen")), joules(row.get("raw")),
            joules(row.get("net")), work if "net" in row else NONE]


def _what_ran(f: dict, containers: int | None) -> str:
    if "wall_per_sim_s_truth" not in f:
        return (f"{len(f['candidates'])} candidate(s) on {f['scene']}, timed alone (--no-truth): no Drake run, so "
                "nothing is off from a truth and nothing is judged.")
    plant = "continuous-time" if f.get("truth_reference") == "continuous" else "discrete"
    boxes = f", {containers} free containers" if containers is not None else ""
    return (f"{f['primary']} against Drake hydroelastic ({plant} plant) on {f['scene']}{boxes}: "
            f"{f['simulated_s_learned']:g} of {f['duration_s']:g} s simulated, plant step {f['time_step_s'] * 1e3:g} ms, "
            f"records every {f['record_period_s'] * 1e3:g} ms, containers at {f['hydroelastic_modulus_Pa']:.0e} Pa.")


def _verdict_text(f: dict) -> str:
    if "wall_per_sim_s_truth" not in f:
        return f"verdict: {f['verdict']}"
    if f["verdict"] is None:
        return f"verdict: none: no gate judges {f['primary']} (the closed-loop gates judge a learned model in the loop)"
    return f"{f['primary']}: {headline(f)}. {verdict_lines(f)[-1]}"


def gate_rows(c: dict) -> list[tuple]:
    """(gate, result, value, threshold) of one judged candidate's gates, then its gates not judged."""
    out = []
    for g in c["gates"]:
        result = ("PASS within its pinned band (known limit)" if is_known_limit(g) else "PASS") if g["passed"] else "FAIL"
        flag = isinstance(g["value"], bool)  # a yes/no gate (no divergence): its result says it
        value = NONE if flag else shown(g["value"], g["unit"])
        threshold = NONE if flag else shown(g["threshold"], g["unit"])
        out.append((g["name"], result, value, threshold))
    out += [(name, "not judged", why, NONE) for name, why in c.get("gates_not_judged", {}).items()]
    return out


def _first_screen(f: dict, containers: int | None) -> list[Section]:
    table_rows = rows(f)
    head = Section(None, [Text(_verdict_text(f)), Text(_what_ran(f, containers)),
                          table([h for _, h in COLUMNS], [cells(r) for r in table_rows])], order=0)
    out = [head]
    judged = [(label, c) for label, c in f["candidates"].items() if c.get("gates")]
    for k, (label, c) in enumerate(judged):
        out.append(Section(f"Gates: {label} ({verdict_cell(c)})", [table(["gate", "result", "value", "threshold"],
                                                                           gate_rows(c))], order=1 + k / 100))
    return out


def _notes(f: dict, actors: list[str]) -> Section:
    h = f["time_step_s"]
    work = (f"the work W(t) of {', '.join(actors)} on the containers since t = 0 (from the records, with the effect's "
            "own force law)" if actors else "the work of the wind, a crane's ropes or a moving deck (none in this scene: "
            "net = raw less the truth's share)")
    items = [
        "real-time factor: simulated time over wall time of the whole run, t = 0 to the end of the window (the start "
        "included: a yard settles in its first tenths of a second); the inverse of compare.json's wall time per "
        f"simulated second. Cost per step: that wall time times the plant step ({h * 1e3:g} ms).",
        "final position / angle error: the largest over the free containers at the last record, against Drake's run "
        "from the same initial state; worst penetration: the deepest container-container (separating-axis depth) or "
        "container-quay penetration of the whole run.",
        "energy raw: max over t of E(t) - E(0) (kinetic + gravity potential, in the plant's world: the deck frame on a "
        f"moving deck); net: max over t of C(t) = E(t) - E(0) - W(t) less Drake's C(t) where positive, W {work}: what "
        "the contact model created, the figure the energy gate reads (its value in the gates table and the red marker "
        "of the plot's last panel); external work max: the largest |W(t)|.",
    ]
    if f.get("cost_learned"):
        items.append(f"where the learned run's wall time goes: {breakdown_line(f['cost_learned'])}")
    if f.get("worst_container") is not None:
        leaves = f.get("leaves_truth_at_s")
        items.append(f"largest position error: {f['worst_container']} at t = {f['worst_time_s']:g} s"
                     + (f"; first 2 cm from the truth at t = {leaves:g} s" if leaves is not None else ""))
    return Section("What the figures are", [Bullets(tuple(items))], order=3)


def layout_of(scenario) -> dict:
    """The yard's layout for the error map (report_plots.error_map_figure): {'sizes': {free
    container: (x, y, z) [m]}, 'welded': [(p (3,), R (3, 3), size) of each welded container]}."""
    sizes = {c.name: tuple(c.container_type().size) for c in scenario.containers if not c.fixed}
    welded = []
    for c in scenario.containers:
        if c.fixed:
            X = c.pose()
            welded.append((X.translation(), X.rotation().matrix(), tuple(c.container_type().size)))
    return {"sizes": sizes, "welded": welded}


def plots(series, under: str, title: str, label: str = "learned", layout=None) -> dict:
    """{file name: matplotlib Figure} of the report: divergence.png and error_map.png
    (report_plots.py) of the run under test `under` in trajectories.npz's arrays `series`."""
    return {DIVERGENCE: report_plots.divergence_figure(series, under, title, label=label),
            ERROR_MAP: report_plots.error_map_figure(series, under, title, layout=layout)}


def sections(f: dict, figures=(), containers: int | None = None, actors=(), files=()) -> list[Section]:
    """The report of compare.json `f`: the first screen (order 0-1), the plots (Figure blocks,
    order 2), what the figures mean (3) and the files of the run (`files`: names in its directory)."""
    out = _first_screen(f, containers)
    if figures:
        out.append(Section("Plots", list(figures), order=2))
    if "wall_per_sim_s_truth" in f:
        out.append(_notes(f, list(actors)))
    if files:
        out.append(Section("Files", [Bullets(tuple(Link(name, name) for name in files))], order=4))
    return out


def title_of(f: dict) -> str:
    """The page's title: the scene and the primary candidate's verdict as the table writes it."""
    if "wall_per_sim_s_truth" not in f:
        return f"testbed compare {f['scene']}: {f['verdict']}"
    primary = f["candidates"][f["primary"]]
    return f"testbed compare {f['scene']}: {f['primary']}: {verdict_cell(primary)}"


def write_report(directory, f: dict, series=None, *, under: str = "learned", label: str = "learned",
                 title: str | None = None, layout=None) -> None:
    """report.html and report.md of compare.json `f` into `directory` (a compare output directory),
    with divergence.png and error_map.png where `series` (trajectories.npz's arrays; under: the run
    under test's prefix there) is given; layout: layout_of the scene (None: the map draws markers)."""
    directory = Path(directory)
    blocks = []
    if series is not None:
        for name, fig in plots(series, under, title or f["scene"], label, layout).items():
            data = png(fig, dpi=90)
            write_atomic(directory / name, data)
            blocks.append(Figure(name, name.removesuffix(".png").replace("_", " "), data))
    listed = sorted(p.name + ("/" if p.is_dir() else "") for p in directory.iterdir() if p.name not in (HTML, MARKDOWN))
    containers = len(series["names"]) if series is not None else None
    actors = [str(a) for a in series["external_actors"]] if series is not None and "external_actors" in series else []
    parts = sections(f, blocks, containers, actors, [*listed, "compare.json"] if "compare.json" not in listed else listed)
    write_atomic(directory / MARKDOWN, to_markdown(title_of(f), parts))
    write_atomic(directory / HTML, to_html(title_of(f), parts))


__all__ = ["COLUMNS", "HTML", "MARKDOWN", "NOT_GATED", "layout_of", "plots", "rows", "sections",
           "verdict_cell", "write_report"]
