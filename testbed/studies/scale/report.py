"""The scale study's report: scale.json (the record), scale.md, scale.html and the chart
scale_cost.png; and the lines `testbed study scale` prints."""

from __future__ import annotations

import math
from pathlib import Path

from testbed.document import Figure, Section, Text, figures, png, pyplot, table, to_html, to_markdown
from testbed.records import write_atomic, write_json
from testbed.studies.scale.cells import SPLIT
from testbed.studies.scale.settings import CLOCKS, from_dict, label
from testbed.studies.scale.targets import targets

TITLE = "Scale study: what a yard of N containers costs"


def _f(value, spec: str, scale: float = 1.0) -> str:
    return "-" if value is None or not math.isfinite(value) else format(value * scale, spec)


def _fit(fit: dict | None) -> str:
    if not fit or not math.isfinite(fit["exponent"]):
        return "-"
    return f"{fit['exponent']:.2f}" + (f" +- {fit['stderr']:.2f}" if math.isfinite(fit["stderr"]) else "")


def _key(study: dict) -> str:
    config = from_dict(study["config"])
    shorter = sorted(n for n in config.sizes if n > config.big_above)
    caps = ", ".join(f"{label(m)} up to N = {n}" for m, n in config.caps if m in config.model_names())
    return (f"Yard blocks of {config.container_type} containers, {config.tiers} tiers, {config.row_gap:g} m between rows, "
            f"{config.bay_gap:g} m between bays, masses drawn from {config.mass_range[0]:g}-{config.mass_range[1]:g} kg "
            f"(seed {config.seed}), every model at the learned law's modulus, at a {config.time_step * 1e3:g} ms step. "
            f"Each run first SETTLES: {config.settle_s:g} s simulated from rest, untimed, by the run's own engine. The "
            f"MuJoCo-hosted learned loop's timed window CONTINUES that run (one run from rest, the window timed inside it): "
            "the learned step's sleeping islands (asleep after 0.3 s below 1e-3 m/s) that fell asleep while settling are "
            "asleep when the window starts (a fresh run would restart their rest timers; the per-size table gives the "
            "fraction of the yard asleep at the window's start and over the window). Every other model settles "
            f"{min(config.settle_s, config.fresh_settle_s):g} s and its window is a fresh run from that settled state "
            "(poses and velocities: Drake's and MuJoCo's own steps keep no sleep state; the Drake-hosted learned loop's "
            f"islands restart awake). The window lasts {config.duration:g} s"
            + (f" ({config.big_duration:g} s at N = {', '.join(map(str, shorter))}, SHORTER at the big sizes)" if shorter else "")
            + ". The start of the window is checked: the largest container speed and the block's kinetic energy there "
            "(against the largest kinetic energy recorded while settling) are in the per-size table. Yards: settled "
            f"(nothing happens) and crane (a {config.crane_mass / 1e3:g} t {config.crane_type} hanging at rest "
            f"{config.crane_gap * 1e3:g} mm above the middle stack (in a continued run: still through the settling, "
            "above the stack's top from rest, which sags meanwhile: the gap at the window's start is in the per-size "
            f"table), lowered at {config.crane_speed:g} m/s and "
            f"{config.crane_acceleration:g} m/s^2 from the window's start: it touches about {config.landing_s() * 1e3:.0f} ms in, "
            "later by the sag in a continued run, and lands inside the window). Wall time is the window's stepping alone "
            "(no recording); CPU time is, in a continued run, this process's over the window's steps alone, else this "
            "process's over the window run less that of a second build and one step, per step: other work on a shared "
            "machine slows the wall time, hardly the CPU time, but the builds' own spread enters it (at N = 1000 a build "
            "costs about as much as the window). Real time: x real time = the step over its cost "
            f"({config.time_step * 1e3:g} ms). The fits and targets read the {config.clock} time. Growth exponent: least-squares "
            f"slope of log(us per step, {config.clock} time) on log(N) over N >= {config.fit_from}, +- its standard "
            "error, per pass "
            f"({config.passes} passes of the whole grid)." + (f" Size caps: {caps} (bigger cells skipped: their cost "
                                                             "per step is far above real time)." if caps else ""))


def _landed(row: dict) -> str:
    """Whether the crane's load landed, and its gap above the stack at the window's start where known."""
    landed = {True: "yes", False: "NO", None: "-"}[row.get("landed")]
    gap = row.get("start_load_clearance_m")
    return landed + (f" ({gap * 1e3:.1f} mm gap at start)" if gap is not None and math.isfinite(gap) else "")


def report_sections(study: dict) -> list[Section]:
    """The study as document sections: key and fits, targets, per-size table, chart, every cell."""
    config, rows = from_dict(study["config"]), study["rows"]
    how = ("one after the other in one process" if study["executor"] == "sequential" else
           f"through {study['executor']} (cells side by side share the machine: timings are disturbed)")
    env = study["environment"]
    runs = (f"Cells run {how}; study wall time {study['wall_s']:.0f} s; {env['cpus']} CPUs, Drake {env['drake']}"
            + "".join(f", {k} {v}" for k, v in env["engines"].items() if k not in ("drake", "learned")) + ".")
    passes = study.get("pass_fits", {})
    key, rtf = CLOCKS[config.clock]
    fits = []
    for y in config.yards:
        for m in config.model_names():
            done = [r for r in rows if r["model"] == m and r["yard"] == y and r["status"] == "ok"]
            big = max(done, key=lambda r: (r["n"], -r[rtf]), default=None)  # the largest N, its slowest pass
            bad = sorted({f"{r['status']} ({r['why']})" for r in rows if r["model"] == m and r["yard"] == y and r["status"] != "ok"})
            fits.append([label(m), y, *(_fit(passes[p][y].get(m)) for p in sorted(passes)), _fit(study["fits"][y].get(m)),
                         f"{_f(big[key], '.0f')} us at N={big['n']}" if big else "-",
                         _f(big[rtf], ".2f") + "x" if big else "-", "; ".join(bad)[:300] or "all ok"])
    per_size = []
    for y in config.yards:
        for m in config.model_names():
            for n in sorted(config.sizes):
                cells = {r["pass"]: r for r in rows if (r["model"], r["yard"], r["n"]) == (m, y, n)}
                ok = [r for r in cells.values() if r["status"] == "ok"]
                if not cells:
                    continue
                first = cells[min(cells)]
                per_size.append([label(m), y, n, *("-" if p not in cells else
                                                    f"{_f(cells[p].get('cpu_us_per_step'), '.2f', 1e-3)} / {_f(cells[p].get('us_per_step'), '.2f', 1e-3)}"
                                                    if cells[p]["status"] == "ok" else cells[p]["status"]
                                                    for p in range(1, config.passes + 1)),
                                 _f(min((r[rtf] for r in ok), default=None), ".2f"),
                                 _f(first.get("start_max_speed_mps"), ".2g"),
                                 f"{_f(first.get('start_kinetic_J'), '.3g')} / {_f(first.get('settle_peak_kinetic_J'), '.3g')}",
                                 _f(first.get("start_asleep_fraction"), ".2f") + " / " + _f(first.get("asleep_fraction"), ".2f"),
                                 _landed(first) if y == "crane" else "-"])
    full = []
    for r in rows:
        ok = r["status"] == "ok"
        s = r.get("split_us") or {}
        full.append([r["pass"], r["n"], r["layout"], label(r["model"]), r["yard"], _f(r.get("simulated_s"), "g"),
                     _f(r.get("real_time_factor"), ".2f") if ok else "-", _f(r.get("us_per_step"), ".0f") if ok else "-",
                     _f(r.get("cpu_us_per_step"), ".0f") if ok else "-",
                     *(_f(s.get(p), ".0f") if ok else "-" for p in SPLIT), _f(r.get("pairs_per_step"), ".1f"),
                     _f(r.get("final_position_error_m"), ".3f", 1e3), r["status"] + (f": {r['why']}" if r["why"] else "")])
    pass_heads = [f"exponent, pass {p}" for p in sorted(passes)]
    return [
        Section("What a yard of N containers costs", [table(
            ["model", "yard", *pass_heads, "exponent, passes pooled", f"per step at the largest N ({config.clock})",
             "x real time there",
             "not ok"], fits), Text(_key(study)), Text(runs)], order=10),
        Section("Targets", [Text("Measured in this run, on this machine (timings are ratios within one run: other work on "
                                 "a shared machine slows every cell)."),
                            table(["target", "measured", "met"], [[x["target"], x["measured"], {True: "yes", False: "NO", None: "-"}[x["met"]]]
                                                                   for x in targets(study)])], order=15),
        Section("Per size", [Text(f"ms per step: CPU / wall time of this process; x real time: the {config.clock} "
                                  f"time's, at the {config.time_step * 1e3:g} ms step, in the slower pass; yard asleep: "
                                  "the fraction of its free containers in asleep islands of the learned step (continued "
                                  "windows only), at the window's first step and averaged over the window."),
                             table(["model", "yard", "N", *(f"ms / step, pass {p}" for p in range(1, config.passes + 1)),
                                    "x real time", "max speed at window start [m/s]",
                                    "kinetic energy at window start / settling peak [J]",
                                    "yard asleep at window start / window mean", "load landed"], per_size)], order=18),
        Section("Cost per step against N", [Figure("scale_cost.png", "cost per step against yard size, log-log",
                                                   cost_chart(rows, study["fits"], config))], order=20),
        Section("Every cell", [table(["pass", "N", "rows x bays x tiers", "model", "yard", "window [s]", "x real time (wall)",
                                      "us / step (wall)", "us / step (CPU)", "engine step [us]", "learned system [us]", "predictor [us]",
                                      "pairs / step", "final pos. error [mm]", "status"], full)], order=30),
    ]


def cost_chart(rows: list[dict], fits: dict, config) -> bytes:
    """PNG of cost_figure."""
    return png(cost_figure(rows, fits, config))


def log_ticks(axis, low: float, high: float) -> None:
    """Labels a log axis spanning [low, high] in plain numbers ('500', '2000', '0.5') at 1, 2 and
    5 of each decade, or at every integer multiple when that leaves fewer than 3 ticks inside
    (a range under about a decade: matplotlib's default then labels one tick or none)."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    for subs in ((1.0, 2.0, 5.0), tuple(float(k) for k in range(1, 10))):
        locator = LogLocator(base=10, subs=subs, numticks=30)
        if sum(low <= t <= high for t in locator.tick_values(low, high)) >= 3:
            break
    axis.set_major_locator(locator)
    axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    axis.set_minor_formatter(NullFormatter())


def cost_figure(rows: list[dict], fits: dict, config):
    """The matplotlib figure: us per step against N (log-log), a curve per model, yard kind
    (settled solid, crane dotted) and pass, labelled with the passes' pooled exponent, and the
    real-time line; the y ticks labelled (log_ticks)."""
    key = CLOCKS[config.clock][0]
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(8, 5.5))
    for i, m in enumerate(config.model_names()):
        for y, style in zip(config.yards, ("o-", "s:")):
            fit = fits.get(y, {}).get(m, {"exponent": float("nan")})
            name = f"{label(m)}, {y}" + (f" (N^{fit['exponent']:.2f})" if math.isfinite(fit["exponent"]) else "")
            for p in sorted({r.get("pass", 1) for r in rows}):  # one line per pass, one legend entry per curve
                pts = sorted((r["n"], r[key]) for r in rows if r["model"] == m and r["yard"] == y and r["status"] == "ok"
                             and r.get("pass", 1) == p and r.get(key) is not None and math.isfinite(r[key]))
                if pts:
                    ax.plot(*zip(*pts), style, label=name, color=f"C{i}", alpha=0.8)
                    name = None
    from matplotlib.ticker import NullLocator

    h_us = 1e6 * config.time_step
    ax.axhline(h_us, color="k", lw=1, ls="--", label=f"real time ({config.time_step * 1e3:g} ms step)")
    ax.set(xscale="log", yscale="log", xlabel="containers N", ylabel=f"{config.clock} time per step [us]",
           title="What a yard costs per step, past the settling transient")
    sizes = sorted({r["n"] for r in rows})
    if sizes:
        ax.set_xticks(sizes, [str(n) for n in sizes])
    ax.xaxis.set_minor_locator(NullLocator())
    low, high = ax.get_ylim()
    log_ticks(ax.yaxis, low, high)
    ax.set_ylim(low, high)
    ax.grid(True, which="major", alpha=0.3)
    ax.legend(fontsize=7)
    return fig


def write_report(study: dict, out) -> list[Path]:
    """Writes scale.json (the record), scale.md, scale.html (self-contained) and the chart
    scale_cost.png into directory `out` (made), each atomically; returns their paths."""
    out = Path(out)
    sections = report_sections(study)
    paths = [write_atomic(out / f.file, f.png) for f in figures(sections)]
    write_json(out / "scale.json", study)
    return paths + [out / "scale.json", write_atomic(out / "scale.md", to_markdown(TITLE, sections)),
                    write_atomic(out / "scale.html", to_html(TITLE, sections))]


def summary_lines(study: dict) -> list[str]:
    """The lines `testbed study scale` prints: one per model and yard (exponents per pass, cost at the largest N)."""
    config, h_us = from_dict(study["config"]), 1e6 * study["config"]["time_step"]
    passes = study.get("pass_fits", {})
    lines = []
    for y in config.yards:
        for m in config.model_names():
            done = [r for r in study["rows"] if r["model"] == m and r["yard"] == y and r["status"] == "ok"]
            if not done:
                why = next((r["why"] for r in study["rows"] if r["model"] == m), "")
                lines.append(f"{label(m):26s} {y:8s} no completed run ({why})")
                continue
            key, rtf = CLOCKS[config.clock]
            big = max(done, key=lambda r: (r["n"], -r[rtf]))
            exps = "/".join(_f(passes[p][y][m]["exponent"], ".2f") for p in sorted(passes))
            lines.append(f"{label(m):26s} {y:8s} N^{exps:10s} {_f(big[key], '9.0f')} us/step ({config.clock}) at N={big['n']:<4d} "
                         f"({_f(big[rtf], '.2f')}x real time, {h_us:g} us budget"
                         + (f", {big['start_asleep_fraction']:.0%} asleep at the window's start)" if
                            math.isfinite(big.get("start_asleep_fraction", math.nan)) else ")"))
    return lines


__all__ = ["TITLE", "cost_chart", "cost_figure", "log_ticks", "report_sections", "summary_lines", "write_report"]
