"""Output of the query study from its metrics alone: the Pareto chart and the report
sections (setup, per-method table, per-set errors, errors by tilt, the paper's Tables 3
and 4 next to today's figures), rendered by testbed.document."""

from __future__ import annotations

import io

from testbed.document import Bullets, Figure, Section, Text, table, to_markdown
from testbed.studies.query import paper

CHART_FILE = "query_pareto.png"
TITLE = "Query study: what accuracy costs in time"


def chart_png(metrics: dict) -> bytes:
    """Pareto chart: mean query time [us] (log) against mean point error [mm] and mean
    normal error [deg] (log), one marker per method, the polygon-soup N sweep joined;
    PNG bytes."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    methods = {k: v for k, v in metrics["methods"].items() if v["available"] and "all" in v}
    fig, axes = plt.subplots(1, 2, figsize=(13, 5.5))
    colours = {"drake": "tab:blue", "polygon_soup": "tab:orange", "mujoco": "tab:green", "learned": "tab:red"}
    floor = {"point_error_m": 1e-2, "normal_error_deg": 1e-4}  # in the plotted units (mm, deg)
    scale = {"point_error_m": 1e3, "normal_error_deg": 1.0}  # m -> mm
    for ax, key, ylabel, front_key in ((axes[0], "point_error_m", "mean contact-point error [mm]", "point_front"),
                                       (axes[1], "normal_error_deg", "mean normal error [deg]", "normal_front")):
        soup = sorted((v["N"], v["all"]["time_us"]["mean"], v["all"][key]["mean"] * scale[key]) for k, v in methods.items()
                      if k.startswith("soup_N") and v["all"][key]["mean"] is not None)
        if soup:
            ax.plot([s[1] for s in soup], [max(s[2], floor[key]) for s in soup], "-", color=colours["polygon_soup"],
                    alpha=0.5, zorder=1)
        for name, v in methods.items():
            t, e = v["all"]["time_us"]["mean"], v["all"][key]["mean"]
            if t is None or e is None:
                continue
            e = e * scale[key]
            on_front = name in metrics["pareto"][front_key]
            is_ref = name == "drake_hydro_cc"
            ax.scatter([t], [max(e, floor[key])], color=colours.get(v["family"], "k"),
                       s=120 if is_ref else (60 if on_front else 30),
                       edgecolors="k" if on_front else "none", zorder=2,
                       marker="*" if is_ref else ("s" if "batched" in name else "o"))
            if not name.startswith("soup_N") or name in (f"soup_N{metrics['config']['soup_N'][0]}",
                                                          f"soup_N{metrics['config']['soup_N'][-1]}"):
                label = f"{name} (reference, error 0)" if is_ref else name
                ax.annotate(label, (t, max(e, floor[key])), fontsize=7, xytext=(4, 3), textcoords="offset points")
        ax.axvline(paper.PAPER_MLP_MS * 1e3, color="tab:red", ls="--", lw=0.8, alpha=0.6)
        ax.text(paper.PAPER_MLP_MS * 1e3, 0.03, " paper's MLP on a 1.5 GHz Pentium IV (0.5 ms)", rotation=90, fontsize=7,
                color="tab:red", transform=ax.get_xaxis_transform(), ha="right", va="bottom")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("mean time per query [us] (log)")
        ax.set_ylabel(ylabel + " (log; reference plotted at the floor)")
        ax.grid(True, which="both", alpha=0.3)
    n = sum(v["n"] for v in metrics["pose_sets"].values())
    fig.suptitle(f"Contact query cost vs accuracy against Drake hydroelastic CoP ({n} poses: "
                 f"{', '.join(metrics['pose_sets'])}); outlined = Pareto front, squares = batched")
    fig.tight_layout()
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=110)
    plt.close(fig)
    return buffer.getvalue()


def _f(x, fmt="{:.3g}") -> str:
    return "-" if x is None else fmt.format(x)


def _mm(x_m) -> str:
    """A length in metres written in mm (the report's unit for lengths)."""
    return "-" if x_m is None else _f(x_m * 1e3)


def markdown(metrics: dict, chart: bytes = b"") -> str:
    """query.md: the study's sections as Markdown (the chart linked as CHART_FILE)."""
    return to_markdown(TITLE, sections(metrics, chart))


def sections(metrics: dict, chart: bytes = b"", *, level: int = 2, order: int = 50,
             chart_file: str = CHART_FILE) -> list[Section]:
    """The study's report sections; `chart`: the Pareto chart's PNG (b"": none), linked
    from Markdown as `chart_file`; `level`: heading level; `order`: of the first section."""
    c, env = metrics["config"], metrics["environment"]
    setup = [
        Text(f"Reference: {metrics['reference']}."),
        Text("Pose sets: " + ", ".join(f"{k} {v['n']} (dropped {v['n_dropped']})" for k, v in metrics["pose_sets"].items())
             + f"; seed {c['seed']} (sampling seed {c['sampling_seed']}); {c['repeats']} timed repeats per pose after a "
             f"warm-up, the fastest kept; BLAS threads while timing: {env.get('blas_threads')}; quick = {c['quick']}."),
        Text(f"Machine: {env['platform']}, {env['cpu_count']} CPUs; Python {env['python']}; packages "
             + ", ".join(f"{k} {v}" for k, v in env["packages"].items()) + "."),
        Text("Times are per query in microseconds, measured side by side in one process (compare ratios, not absolute "
             "values). *query* = pose in, point and normal out (Python included); *kernel* = the library's collision "
             "call alone. Batched methods: one call per pose set, its time divided by the set's size (p99/max over "
             "repeats); their throughput at larger batches is listed under the tables. Errors: contact point [mm] and "
             "normal [deg] against the reference."),
    ]
    out = [Section(None, setup, order, level)]
    out.append(Section("Methods (all pose sets)", _methods_blocks(metrics, chart, chart_file), order + 1, level))
    out.append(Section("Errors by pose set (mean point error [mm] / mean normal error [deg] / mean query time [us])",
                       [_by_set_table(metrics)], order + 2, level))
    tilt = metrics.get("near_parallel_by_tilt") or {}
    if tilt:
        rows = []
        for name, per_decade in tilt["methods"].items():
            cells = []
            for r in per_decade:
                cell = _mm(r["point_error_m"])
                if name.startswith("soup") and r["count_max"] is not None:
                    cell += f" ({r['count_max']})"
                cells.append(cell)
            rows.append([name, *cells])
        out.append(Section("Near-parallel worst case by tilt (mean point error [mm]; soup: max colliding pairs)",
                           [table(["method", *tilt["decades"]], rows)], order + 3, level))
    out.append(Section("The paper's Tables 3 and 4 on today's tools", _paper_blocks(metrics), order + 4, level))
    return out


def _methods_blocks(metrics: dict, chart: bytes, chart_file: str) -> list:
    rows = []
    for name, v in metrics["methods"].items():
        if not v["available"]:
            rows.append([name, f"not available: {v['reason']}"] + [""] * 11)
            continue
        a = v["all"]
        t, k, p, nr = a["time_us"], a.get("kernel_time_us"), a["point_error_m"], a["normal_error_deg"]
        rows.append([name, _f(t["mean"]), _f(t["p99"]), _f(t["max"]), _f(k["mean"]) if k else "-", _mm(p["mean"]),
                     _mm(p["median"]), _mm(p["p99"]), _mm(p["max"]), _f(nr["mean"]), _f(nr["p99"]), _f(nr["max"]),
                     p["n_missing"]])
    blocks = [table(["method", "query mean", "p99", "max", "kernel mean", "point err mean [mm]", "median", "p99", "max",
                     "normal err mean [deg]", "p99", "max", "missing"], rows),
              Text(f"Pareto front (mean time vs mean point error): {', '.join(metrics['pareto']['point_front'])}."),
              Text(f"Pareto front (mean time vs mean normal error): {', '.join(metrics['pareto']['normal_front'])}.")]
    if chart:
        blocks.append(Figure(chart_file, "Pareto chart", chart))
    return blocks


def _by_set_table(metrics: dict):
    rows = []
    for name, v in metrics["methods"].items():
        if not v["available"]:
            continue
        cells = []
        for s in metrics["pose_sets"]:
            b = v["by_set"].get(s)
            cells.append("-" if b is None else f"{_mm(b['point_error_m']['mean'])} / {_f(b['normal_error_deg']['mean'])}"
                         f" / {_f(b['time_us']['mean'])}")
        rows.append([name, *cells])
    return table(["method", *metrics["pose_sets"]], rows)


def _paper_blocks(metrics: dict) -> list:
    soup, env = metrics["polygon_soup"], metrics["environment"]
    p3, p4 = metrics["paper"]["table3"], metrics["paper"]["table4"]
    t3 = [[n, s["triangles_per_box"], _f(p3.get(n, {}).get("avg_ms")),
           f"{_f(s['avg_kernel_ms'])} ({_f(s['avg_kernel_ms_typical'])})", _f(s["avg_query_ms"])] for n, s in soup.items()]
    t4 = [[n, _f(p4.get(n, {}).get("max_tests"), "{}"), _f(p4.get(n, {}).get("worst_ms")), s["max_colliding_pairs"],
           _f(s["kernel_ms_at_max_pairs"]), s["max_candidate_pairs"], _f(s["worst_kernel_ms"]), _f(s["worst_query_ms"])]
          for n, s in soup.items()]
    learned = []
    for k in ("paper_mlp_single", "paper_mlp_batched", "improved_single", "improved_batched"):
        v = metrics["methods"][k]
        if v["available"]:
            t, thr = v["all"]["time_us"], v.get("throughput_us_per_pair")
            learned.append(f"{k}: mean {_f(t['mean'] * 1e-3)} ms, max {_f(t['max'] * 1e-3)} ms per query"
                           + (f"; {_f(thr)} us per pair in batches of {v['throughput_batch']}" if thr else ""))
        else:
            learned.append(f"{k}: not available ({v['reason']})")
    return [
        Text("Paper: RAPID on a Pentium IV at 1.5 GHz, timed with gprof over its 75,000-pattern test set. Its Table 3 "
             "column \"Triangles/face\" holds 12 N^2, the triangles of a whole box (2N^2 per face). Today: python-fcl "
             f"{env['packages'].get('python-fcl')} (FCL, OBBRSS trees), kernel = fcl.collide with every contact "
             "requested, over all pose sets here (\"typical\" = stacking and general only). The paper's MLP took "
             f"{paper.PAPER_MLP_MS} ms per query."),
        Text("Table 3 (average time per query):"),
        table(["N", "triangles/box", "paper Table 3 avg [ms]", "today avg kernel [ms] (typical)", "today avg query [ms]"], t3),
        Text("Table 4 (the pose with the most triangle tests). Paper \"Max. test\" counts RAPID's triangle tests; FCL "
             "does not expose its test counter, so today's columns give the colliding triangle pairs (exact) and the "
             "candidate pairs (triangle pairs whose axis-aligned bounds overlap: the leaf tests an ideal AABB tree "
             "must make)."),
        table(["N", "paper max tests", "paper worst [ms]", "today max colliding pairs", "kernel at that pose [ms]",
               "today max candidate pairs", "worst kernel [ms]", "worst query [ms]"], t4),
        Text("Learned models today (paper: about 0.5 ms per query):"),
        Bullets(tuple(learned)),
        Text(f"Wall time: {metrics['wall_time_s']['total']:.1f} s (labels {metrics['wall_time_s']['labels']:.1f} s)."),
    ]
