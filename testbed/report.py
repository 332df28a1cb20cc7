"""Validation report: gates, metrics.json, summary.md and a self-contained index.html.

Gates are evaluated here from the case results (each with its threshold and why);
`metrics.json` follows testbed/report_schema.json (version SCHEMA_VERSION).
"""

import base64
import datetime
import html
import io
import json
import math
import os
import platform
from pathlib import Path

from testbed.validate import REST_WINDOW_S, SCHEMA_VERSION, _json_default, _write_atomic

# Gate thresholds and their reasons (stated once, used in the report).
# At rest a container pair overlaps ~0.25 mm per contact under its own weight (sdf/README.md);
# 5 mm at rest means the contact is far too soft for stacking (9 contacts would sink 4.5 cm).
MAX_RESTING_PENETRATION_M = 0.005
FORCE_BALANCE_TOL = 0.01  # at rest, contact forces on the ground carry the total weight within 1%
FORCE_BALANCE_WINDOW_S = REST_WINDOW_S  # averaged over the last 0.5 s (point contact hops between corners)


def _gate(name, passed, value, threshold, unit, description) -> dict:
    return {"name": name, "passed": bool(passed), "value": value, "threshold": threshold, "unit": unit,
            "description": description}


def evaluate_gates(results: list[dict]) -> list[dict]:
    gates = []
    for r in results:
        if r["status"] != "ok":
            gates.append(_gate(f"{r['id']}: ran", False, r["result"].get("error"), None, "",
                               "the case finished without an exception"))
            continue
        if r["kind"] == "scene":
            s = r["result"]
            gates.append(_gate(f"{r['id']}: finite state", s["finite_state"], s["finite_state"], True, "",
                               "no NaN or inf in the final state"))
            gates.append(_gate(f"{r['id']}: resting penetration", s["resting_penetration_m"] < MAX_RESTING_PENETRATION_M,
                               s["resting_penetration_m"], MAX_RESTING_PENETRATION_M, "m",
                               f"largest penetration of any pair over the last {FORCE_BALANCE_WINDOW_S} s"))
            balance = s.get("ground_force_over_weight", float("nan"))
            if "crane" in s.get("effects", []):
                continue  # the ropes carry part of the load until the twistlocks release
            gates.append(_gate(f"{r['id']}: force balance", abs(balance - 1.0) <= FORCE_BALANCE_TOL, balance,
                               [1 - FORCE_BALANCE_TOL, 1 + FORCE_BALANCE_TOL], "x weight",
                               f"mean normal force on the ground over the last {FORCE_BALANCE_WINDOW_S} s / total weight"))
        elif r["kind"] == "learned_gates":
            for g in r["result"].get("gates", []):
                gates.append(_gate(f"learned: {g['name']}", g["passed"], g["value"], g["threshold"], g.get("unit", ""),
                                   g.get("description", "")))
    return gates


def _environment() -> dict:
    import numpy
    import pydrake

    return {"python": platform.python_version(), "platform": platform.platform(), "numpy": numpy.__version__,
            "drake": getattr(pydrake, "__version__", "unknown"), "cpus": os.cpu_count()}


def build_metrics(spec: dict, results: list[dict]) -> dict:
    gates = evaluate_gates(results)
    return {
        "schema": SCHEMA_VERSION,
        "suite": spec.get("suite", "custom"),
        "created": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "environment": _environment(),
        "passed": all(g["passed"] for g in gates),
        "gates": gates,
        "cases": {r["id"]: {k: v for k, v in r.items() if k != "id"} for r in results},
    }


def write_report(run_dir: Path, spec: dict, results: list[dict]) -> dict:
    metrics = build_metrics(spec, results)
    metrics["replays"] = {p.name: (f"replays/{p.name}/replay.html" if (p / "replay.html").exists()
                                   else (p / "error.txt").read_text().strip() if (p / "error.txt").exists() else "missing")
                          for p in sorted((run_dir / "replays").glob("*")) if p.is_dir()}
    _write_atomic(run_dir / "metrics.json", json.dumps(_strip_images(metrics), indent=1, default=_json_default))
    _write_atomic(run_dir / "summary.md", summary_markdown(metrics))
    _write_atomic(run_dir / "index.html", index_html(metrics))
    return metrics


def _strip_images(metrics: dict) -> dict:
    """metrics.json keeps numbers, not embedded images."""
    out = json.loads(json.dumps(metrics, default=_json_default))
    for case in out["cases"].values():
        if isinstance(case.get("result"), dict):
            case["result"].pop("pareto_png_hex", None)
            case["result"].pop("traceback", None)
    return out


# ----------------------------------------------------------------------------- text


def _fmt(value, unit="") -> str:
    if isinstance(value, bool) or value is None:
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "n/a"
        if unit == "m":
            return f"{value * 1e3:.2f} mm"
        return f"{value:.4g}"
    if isinstance(value, list):
        return "[" + ", ".join(_fmt(v) for v in value) + "]"
    return str(value)


def _scene_rows(metrics):
    for cid, case in metrics["cases"].items():
        if case["kind"] == "scene" and case["status"] == "ok":
            yield cid, case["params"], case["result"]


def _worst_learned(metrics):
    worst = None
    for cid, params, s in _scene_rows(metrics):
        value = s.get("learned_vs_hydro_point_error_max_m")
        if value is not None and (worst is None or value > worst[1]):
            worst = (cid, value, s.get("learned_vs_hydro_point_error_worst_step"))
    return worst


def summary_markdown(metrics: dict) -> str:
    failed = [g for g in metrics["gates"] if not g["passed"]]
    lines = [f"# Validation ({metrics['suite']} suite): {'PASS' if metrics['passed'] else 'FAIL'}", "",
             f"{len(metrics['gates']) - len(failed)}/{len(metrics['gates'])} gates pass."]
    for g in failed:
        lines.append(f"- FAILED {g['name']}: {_fmt(g['value'], g['unit'])} (threshold {_fmt(g['threshold'], g['unit'])})")
    worst = _worst_learned(metrics)
    if worst:
        lines.append(f"\nPredictor worst case: {worst[0]}, point error {worst[1] * 100:.1f} cm at step {worst[2]}.")
    for name, link in metrics.get("replays", {}).items():
        lines.append(f"Replay of {name}: {link}")
    lines += ["", "## Scenes", "",
              "Learned errors are against the hydroelastic centre of pressure and normal the predictor is trained for",
              "(the driving model's, or the shadow's when a scene drives with point contact).", "",
              "| case | real-time factor | max penetration | shadow CoP disagreement max | learned point error median / p95 / max | learned normal error max |",
              "|---|---:|---:|---:|---:|---:|"]
    for cid, params, s in _scene_rows(metrics):
        learned = (f"{s['learned_vs_hydro_point_error_median_m'] * 100:.1f} / {s['learned_vs_hydro_point_error_p95_m'] * 100:.1f} / "
                   f"{s['learned_vs_hydro_point_error_max_m'] * 100:.1f} cm | {s['learned_vs_hydro_normal_error_max_deg']:.2f} deg"
                   ) if "learned_vs_hydro_point_error_median_m" in s else "n/a | n/a"
        lines.append(f"| {cid} | {s['real_time_factor']:.2f} | {s['max_penetration_m'] * 1e3:.2f} mm | "
                     f"{s.get('shadow_cop_distance_max_m', float('nan')) * 100:.1f} cm | {learned} |")
    lines += ["", "## Simulation study (cost vs accuracy)", "",
              "| scene | model | approximation | time step | ms / sim s | deviation | max penetration | energy gain | status |",
              "|---|---|---|---:|---:|---:|---:|---:|---|"]
    for row in _sim_rows(metrics):
        lines.append(f"| {row['scene']} | {row['model']} | {row['approximation']} | {row['time_step']:g} | "
                     f"{row['ms_per_sim_second']:.0f} | {row['deviation_m'] * 1e3:.3f} mm | "
                     f"{row['max_penetration_m'] * 1e3:.2f} mm | {row['energy_gain_J']:.1f} J | {row['status']} |")
    lines += ["", "## What each effect costs (wall time with the effect / bare)", ""]
    for cid, case in metrics["cases"].items():
        if case["kind"] == "effect_costs" and case["status"] == "ok":
            for row in case["result"]["rows"]:
                ratio = f"{row['ratio']:.2f}x" if row.get("status") == "ok" else row.get("status")
                lines.append(f"- {case['result']['scene']}: {row['effect']}: {ratio}")
    rows = list(stability_rows(metrics))
    if rows:
        lines += ["", "## Stability matrix (unstable entries)", ""]
        unstable = [r for r in rows if not r["stable"]]
        lines += [f"- {r['case']} / {r['model']} / {r['approximation']} / h = {r['time_step']:g} s: {r['failed']}" for r in unstable]
        lines.append(f"\n{len(rows) - len(unstable)} of {len(rows)} grid entries stable.")
    query = _query(metrics)
    if query:
        lines += ["", "## Query study", "", query.get("markdown", "(see index.html)")]
    return "\n".join(lines) + "\n"


def _sim_rows(metrics):
    for case in metrics["cases"].values():
        if case["kind"] == "sim_sweep" and case["status"] == "ok":
            yield from case["result"]["rows"]


def stability_rows(metrics):
    for case in metrics["cases"].values():
        if case["kind"] == "stability" and case["status"] == "ok":
            yield from case["result"]["rows"]


def stability_matrix(rows) -> tuple[list[str], list[list[str]]]:
    """(column labels, rows) of the matrix: case x (model, approximation, time step)."""
    columns, table = [], {}
    for r in rows:
        column = f"{r['model']} / {r['approximation']} / {r['time_step']:g} s"
        if column not in columns:
            columns.append(column)
        cell = "stable" if r["stable"] else f"UNSTABLE: {r['failed']}"
        if r["case"].startswith("wobble"):
            cell += f" (sigma/h2g {r.get('sigma_phi_over_h2g', float('nan')):.3g} at h sqrt(k/m) {r.get('h_sqrt_k_over_m', float('nan')):.2f})"
        table.setdefault(r["case"], {})[column] = cell
    return columns, [[case] + [cells.get(c, "") for c in columns] for case, cells in table.items()]


def _query(metrics):
    for case in metrics["cases"].values():
        if case["kind"] == "query_study" and case["status"] == "ok":
            return case["result"].get("metrics", {})
    return None


# ----------------------------------------------------------------------------- html


def _png(fig) -> str:
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=110, bbox_inches="tight")
    import matplotlib.pyplot as plt

    plt.close(fig)
    return base64.b64encode(buffer.getvalue()).decode()


def _plots(metrics: dict) -> dict[str, str]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plots = {}
    rows = list(_sim_rows(metrics))
    if rows:
        fig, ax = plt.subplots(figsize=(6.5, 4.2))
        curves = {}
        for r in rows:
            curves.setdefault((r["scene"], r["model"], r["approximation"]), []).append(r)
        for (scene, model, approximation), points in sorted(curves.items()):
            points = [p for p in points if p["status"] == "ok" and math.isfinite(p["deviation_m"])]
            points.sort(key=lambda p: p["ms_per_sim_second"])
            if points:
                ax.plot([p["ms_per_sim_second"] for p in points], [max(p["deviation_m"], 1e-9) for p in points],
                        "o-", label=f"{scene} {model} {approximation}")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("wall time per simulated second [ms]")
        ax.set_ylabel("RMS deviation from 0.1 ms reference [m]")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
        ax.set_title("Simulation cost vs accuracy (one curve per contact configuration)")
        plots["sim"] = _png(fig)
    effect_rows = [(c["result"]["scene"], r) for c in metrics["cases"].values()
                   if c["kind"] == "effect_costs" and c["status"] == "ok" for r in c["result"]["rows"] if r.get("status") == "ok"]
    if effect_rows:
        fig, ax = plt.subplots(figsize=(6.5, 3.2))
        ax.bar([f"{s}\n{r['effect']}" for s, r in effect_rows], [r["ratio"] for s, r in effect_rows], color="#4a7ab5")
        ax.axhline(1.0, color="k", lw=0.8)
        ax.set_ylabel("wall time / bare scene")
        ax.set_title("What each effect costs")
        ax.tick_params(axis="x", labelsize=7)
        plots["effects"] = _png(fig)
    for case in metrics["cases"].values():
        if case["kind"] == "query_study" and case["status"] == "ok" and case["result"].get("pareto_png_hex"):
            plots["query"] = base64.b64encode(bytes.fromhex(case["result"]["pareto_png_hex"])).decode()
    return plots


def markdown_html(text: str) -> str:
    """The small Markdown subset the studies write (#-headings, pipe tables, lists,
    paragraphs) as HTML; everything escaped. Images are left out (plots are embedded)."""
    out, table, paragraph = [], [], []

    def flush():
        if table:
            rows = [[c.strip() for c in line.strip().strip("|").split("|")] for line in table
                    if not set(line.replace("|", "").strip()) <= set("-: ")]
            out.append(_table(rows[0], rows[1:]))
            table.clear()
        if paragraph:
            out.append(f"<p>{html.escape(' '.join(paragraph))}</p>")
            paragraph.clear()

    for line in text.splitlines():
        stripped = line.strip()
        if stripped.startswith("|"):
            if paragraph:
                flush()
            table.append(stripped)
            continue
        if table or not stripped or stripped.startswith(("#", "- ", "![")):
            flush()
        if not stripped or stripped.startswith("!["):
            continue
        if stripped.startswith("#"):
            level = min(6, len(stripped) - len(stripped.lstrip("#")) + 2)
            out.append(f"<h{level}>{html.escape(stripped.lstrip('#').strip())}</h{level}>")
        elif stripped.startswith("- "):
            out.append(f"<ul><li>{html.escape(stripped[2:])}</li></ul>")
        else:
            paragraph.append(stripped)
    flush()
    return "".join(out)


def _table(headers, rows) -> str:
    head = "".join(f"<th>{html.escape(str(h))}</th>" for h in headers)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in row) + "</tr>" for row in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def index_html(metrics: dict) -> str:
    plots = _plots(metrics)
    failed = [g for g in metrics["gates"] if not g["passed"]]
    verdict = "PASS" if metrics["passed"] else "FAIL"
    worst = _worst_learned(metrics)
    parts = [f"<h1>Container contact testbed: validation ({html.escape(metrics['suite'])} suite)</h1>",
             f"<p class='verdict {verdict.lower()}'>{verdict}: {len(metrics['gates']) - len(failed)} of "
             f"{len(metrics['gates'])} gates pass.</p>"]
    if failed:
        parts.append("<h2>Failed gates</h2>" + _table(["gate", "value", "threshold", "what"], [
            (g["name"], _fmt(g["value"], g["unit"]), _fmt(g["threshold"], g["unit"]), g["description"]) for g in failed]))
    if worst:
        parts.append(f"<p>Predictor worst case: <b>{html.escape(worst[0])}</b>, point error {worst[1] * 100:.1f} cm "
                     f"at step {worst[2]}.</p>")
    if metrics.get("replays"):
        items = "".join(
            f"<li><a href='{html.escape(v)}'>{html.escape(k)}</a></li>" if v.endswith(".html")
            else f"<li>{html.escape(k)}: no replay ({html.escape(v)})</li>" for k, v in metrics["replays"].items())
        parts.append("<p>Meshcat replays of the worst learned cases (self-contained, open from disk; overlays: "
                     f"truth cyan, shadow magenta, learned yellow, errors green to red):</p><ul>{items}</ul>")
    if "query" in plots:
        parts.append("<h2>What accuracy costs in time (per query)</h2>"
                     f"<img src='data:image/png;base64,{plots['query']}' alt='query Pareto chart'>")
    query = _query(metrics)
    if query and query.get("markdown"):
        parts.append(f"<div class='study'>{markdown_html(query['markdown'])}</div>")
    if "sim" in plots:
        parts.append("<h2>What accuracy costs in time (whole simulations)</h2>"
                     f"<img src='data:image/png;base64,{plots['sim']}' alt='simulation study'>")
    rows = list(_sim_rows(metrics))
    if rows:
        parts.append(_table(["scene", "model", "approximation", "time step [s]", "ms / sim s", "deviation [mm]",
                             "max penetration [mm]", "energy gain [J]", "status"],
                            [(r["scene"], r["model"], r["approximation"], f"{r['time_step']:g}",
                              f"{r['ms_per_sim_second']:.0f}", f"{r['deviation_m'] * 1e3:.3f}",
                              f"{r['max_penetration_m'] * 1e3:.2f}", f"{r['energy_gain_J']:.1f}", r["status"]) for r in rows]))
    rows = list(stability_rows(metrics))
    if rows:
        columns, table = stability_matrix(rows)
        parts.append("<h2>Stability matrix</h2><p>Case x contact model / approximation / time step. A cell names "
                     "the criterion that failed and its figure (testbed/studies/stability.py states each criterion).</p>"
                     + _table(["case"] + columns, table))
    if "effects" in plots:
        parts.append(f"<h2>What each effect costs</h2><img src='data:image/png;base64,{plots['effects']}' alt='effect costs'>")
    scene_rows = [(cid, f"{s['real_time_factor']:.2f}", f"{s['max_penetration_m'] * 1e3:.2f}",
                   f"{s.get('shadow_cop_distance_max_m', float('nan')) * 100:.1f}",
                   f"{s.get('learned_vs_hydro_point_error_median_m', float('nan')) * 100:.1f}",
                   f"{s.get('learned_vs_hydro_point_error_max_m', float('nan')) * 100:.1f}",
                   f"{s.get('learned_vs_hydro_normal_error_max_deg', float('nan')):.2f}")
                  for cid, params, s in _scene_rows(metrics)]
    if scene_rows:
        parts.append("<h2>Scenes</h2><p>Learned errors are against the hydroelastic answer the predictor is "
                     "trained for (the shadow's when a scene drives with point contact).</p>" + _table(["case", "real-time factor", "max penetration [mm]",
                                                 "shadow CoP disagreement max [cm]", "learned point error median [cm]",
                                                 "learned point error max [cm]", "learned normal error max [deg]"], scene_rows))
    parts.append("<h2>All gates</h2>" + _table(["gate", "passed", "value", "threshold", "what"], [
        (g["name"], "yes" if g["passed"] else "NO", _fmt(g["value"], g["unit"]), _fmt(g["threshold"], g["unit"]),
         g["description"]) for g in metrics["gates"]]))
    env = metrics["environment"]
    parts.append(f"<p class='env'>{html.escape(metrics['created'])}; Drake {html.escape(str(env['drake']))}, "
                 f"Python {html.escape(env['python'])}, {env['cpus']} CPUs. Timings are indicative: compare ratios "
                 "within this report, not absolute times across machines.</p>")
    style = ("body{font-family:sans-serif;max-width:70em;margin:2em auto;color:#222}table{border-collapse:collapse;"
             "margin:1em 0;font-size:90%}td,th{border:1px solid #ccc;padding:3px 7px;text-align:right}"
             "th{background:#f0f0f0}.verdict{font-size:140%;font-weight:bold}.pass{color:#17803d}.fail{color:#b3261e}"
             "img{max-width:100%}.env{color:#777;font-size:85%}pre{background:#f7f7f7;padding:1em;overflow:auto}")
    return (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>Validation report</title>"
            f"<style>{style}</style></head><body>{''.join(parts)}</body></html>\n")
