"""Writes the accuracy report of a training run: metrics.json and report.md.

`write_report(metrics, out_dir)` is what the CLI calls; `metrics` is the dict returned
by training.train_default (or read back from a metrics.json).
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np

from learned_contact.evaluation.metrics import PAPER_OUTPUT_NAMES, PAPER_TABLE_1, PAPER_TABLE_2
from learned_contact.predictors.improved import SHIPPED_DIR

_SPLITS = ("train", "validation", "external")


def _paper_rows(tables: dict) -> list[str]:
    """tables: split -> paper_table dict. Markdown rows per measure and output."""
    rows = ["| measure | output | " + " | ".join(_SPLITS) + " |", "|---|---|" + "---|" * len(_SPLITS)]
    for measure in ("ME", "MAE", "RMSE"):
        for out in (*PAPER_OUTPUT_NAMES, "mean"):
            vals = [f"{tables[s][out][measure]:.4f}" if s in tables else "-" for s in _SPLITS]
            rows.append(f"| {measure} | {out} | " + " | ".join(vals) + " |")
        for label, ref in (("paper Table 2", PAPER_TABLE_2), ("paper Table 1", PAPER_TABLE_1)):
            rows.append(f"| {measure} | *{label}* | " + " | ".join(f"{ref[s][measure]:.4f}" for s in _SPLITS) + " |")
    return rows


def _stat_row(name: str, st: dict, scale: float = 1.0, fmt: str = "{:.4f}") -> str:
    vals = [fmt.format(st[k] * scale) for k in ("median", "p95", "p99", "max")]
    return f"| {name} | {st['n']} | " + " | ".join(vals) + " |"


def render_markdown(metrics: dict) -> str:
    lines = ["# learned_contact accuracy report", "",
             "Labels: Drake's static hydroelastic answer (the centre of pressure as the exact integral of",
             "Drake's pressure field over its contact surface, not the one-point rule its discrete solver",
             "applies; pressure-weighted normal A->B; in A's frame). Paper outputs: spherical angles [rad] of the contact point",
             "direction and force direction in the symmetry-reduced frame (encodings.PAPER_FRAME);",
             "azimuth errors wrapped. Paper figures are its Tables 1 and 2 (averaged over outputs).", ""]
    paper = metrics.get("paper", {})
    if paper:
        lines += ["## Paper-faithful MLP (6-20-18-4 tanh, SGD+momentum, early stopping, restarts)", "",
                  "Sets: general distribution; " + ", ".join(f"{s} n={paper[s]['n']}" for s in _SPLITS if s in paper), ""]
        lines += _paper_rows({s: paper[s]["paper_table"] for s in paper})
        lines.append("")
    improved = metrics.get("improved", {})
    if improved:
        lines += ["## Improved predictor", ""]
        for dist in ("general", "stacking"):
            tables = {s: improved[f"{s}/{dist}"]["paper_table"] for s in _SPLITS if f"{s}/{dist}" in improved}
            lines += [f"### Paper table, {dist}", ""] + _paper_rows(tables) + [""]
        for key, ev in improved.items():
            if not key.startswith("external/"):
                continue
            lines += [f"### Contact point and normal errors, {key} (n={ev['n']})", "",
                      "| subset | n | median | p95 | p99 | max |", "|---|---|---|---|---|---|"]
            lines.append(_stat_row("point [m], all", ev["point_m"]))
            lines.append(_stat_row("point [% of A's length], all", ev["point_pct_length"], fmt="{:.3f}"))
            lines.append(_stat_row("normal [deg], all", ev["normal_deg"], fmt="{:.3f}"))
            for t, sub in ev["by_type"].items():
                if sub["point_m"]["n"]:
                    lines.append(_stat_row(f"point [m], {t}", sub["point_m"]))
                    lines.append(_stat_row(f"point [%], {t}", sub["point_pct_length"], fmt="{:.3f}"))
                    lines.append(_stat_row(f"normal [deg], {t}", sub["normal_deg"], fmt="{:.3f}"))
            lines.append("")
    drake = metrics.get("drake_point_contact", {})
    if drake:
        lines += ["## For reference: Drake's point contact against the same labels", "",
                  "| set | n | point median [m] | point p95 [m] | normal median [deg] | normal p95 [deg] | paper MAE [rad] |",
                  "|---|---|---|---|---|---|---|"]
        for key, ev in drake.items():
            lines.append(f"| {key} | {ev['n']} | {ev['point_m']['median']:.4f} | {ev['point_m']['p95']:.4f} | "
                         f"{ev['normal_deg']['median']:.3f} | {ev['normal_deg']['p95']:.3f} | "
                         f"{ev['paper_table']['mean']['MAE']:.4f} |")
        lines.append("")
    if "wall_time_s" in metrics:
        lines += ["## Run", "", "Wall time [s]: " + ", ".join(f"{k} {v:.0f}" for k, v in metrics["wall_time_s"].items()), ""]
    return "\n".join(lines)


def weights_digest(path) -> str:
    """SHA-256 over a weights file's float arrays (name, then bytes, names sorted): what metrics.json's
    "weights_sha256" records of the weights it scored. Any changed bit of any weight changes it; the
    zip's own bytes (timestamps, compression) do not."""
    h = hashlib.sha256()
    with np.load(path) as z:
        for name in sorted(z.files):
            a = z[name]
            if a.dtype.kind == "f":
                h.update(name.encode())
                h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


def write_report(metrics: dict, out_dir) -> tuple[Path, Path]:
    """Writes out_dir/metrics.json and out_dir/report.md; returns their paths."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    js = out_dir / "metrics.json"
    md = out_dir / "report.md"
    js.write_text(json.dumps(metrics, indent=1, default=float) + "\n")
    md.write_text(render_markdown(metrics) + "\n")
    return js, md


def write_shipped_report(out_dir) -> tuple[Path, Path]:
    """Copies the shipped model's figures (shipped/metrics.json) into out_dir as
    metrics.json + report.md (for `testbed` reports without retraining)."""
    metrics = json.loads((SHIPPED_DIR / "metrics.json").read_text())
    return write_report(metrics, out_dir)
