"""Writing a calibration's output: metrics.json, per-toss errors, plots and a short report.md."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from testbed.calibration.data import CUBE_WIDTH, TossSet
from testbed.calibration.rollout import TossResult, TossSimulator


def write_metrics(out: Path, metrics: dict) -> None:
    (out / "metrics.json").write_text(json.dumps(metrics, indent=2, sort_keys=True) + "\n")


def write_per_toss(out: Path, results: list[TossResult], split: dict[int, str] | None = None) -> None:
    """per_toss.csv: toss_id, split, position error [cube widths], rotation error [deg], failed."""
    lines = ["toss_id,split,position_error,rotation_error_deg,failed"]
    for r in results:
        side = (split or {}).get(r.toss_id, "all")
        lines.append(f"{r.toss_id},{side},{r.position_error:.6f},{r.rotation_error_deg:.4f},{int(r.failed)}")
    (out / "per_toss.csv").write_text("\n".join(lines) + "\n")


def plot_errors(out: Path, results: list[TossResult], split: dict[int, str] | None = None) -> Path:
    """error_per_toss.png: position error of every toss (sorted), coloured by split side."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    order = np.argsort([r.position_error for r in results])
    fig, ax = plt.subplots(figsize=(8, 3.5))
    colours = {"train": "tab:blue", "test": "tab:orange", "all": "tab:gray"}
    sides = [(split or {}).get(results[i].toss_id, "all") for i in order]
    ax.bar(np.arange(len(order)), [100 * results[i].position_error for i in order], color=[colours[s] for s in sides], width=1.0)
    for side, colour in colours.items():
        if side in sides:
            ax.bar([], [], color=colour, label=side)
    ax.axhline(13.5, color="k", ls="--", lw=0.8, label="Drake, Acosta et al. (13.5%)")
    ax.set_xlabel("toss (sorted by error)")
    ax.set_ylabel("position error [% of cube width]")
    ax.legend(fontsize=8)
    fig.tight_layout()
    path = out / "error_per_toss.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_trajectories(out: Path, data: TossSet, results: list[TossResult], sim: TossSimulator, count: int = 4,
                      initial: str = "first-frame") -> Path:
    """trajectories.png: data vs simulation (x, y, z of the centre) for tosses at the
    error quantiles 0, 1/3, 2/3 and 1 (best to worst), rolled out from `initial` states."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    by_id = {t.toss_id: t for t in data.tosses}
    ranked = sorted(results, key=lambda r: r.position_error)
    picks = [ranked[int(round(q * (len(ranked) - 1)))] for q in np.linspace(0, 1, count)]
    fig, axes = plt.subplots(1, count, figsize=(3.2 * count, 3.2), squeeze=False)
    for ax, r in zip(axes[0], picks):
        toss = by_id[r.toss_id]
        try:
            p, _ = sim.rollout(toss, initial)
        except RuntimeError:
            continue
        for j, (name, colour) in enumerate((("x", "tab:red"), ("y", "tab:green"), ("z", "tab:blue"))):
            ax.plot(toss.t, toss.p_WB[:, j] / CUBE_WIDTH, color=colour, lw=1.5, label=f"{name} data")
            ax.plot(toss.t, p[:, j] / CUBE_WIDTH, color=colour, lw=1.0, ls="--", label=f"{name} sim")
        ax.set_title(f"toss {r.toss_id}: {100 * r.position_error:.1f}%", fontsize=9)
        ax.set_xlabel("t [s]")
    axes[0][0].set_ylabel("position [cube widths]")
    axes[0][-1].legend(fontsize=6)
    fig.tight_layout()
    path = out / "trajectories.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def markdown(title: str, rows: dict[str, dict], params: dict, notes: str = "") -> str:
    """report.md: a metrics table (one row per split) and the parameters."""
    lines = [f"# {title}", "", "| tosses | n | position error mean | median | rotation error mean [deg] | failed |",
             "|---|---|---|---|---|---|"]
    for name, m in rows.items():
        lines.append(f"| {name} | {m['n_trajectories']} | {100 * m['position_error_mean']:.2f}% | "
                     f"{100 * m['position_error_median']:.2f}% | {m['rotation_error_mean_deg']:.1f} | {m.get('n_failed', 0)} |")
    lines += ["", "Position error: mean over frames of |p_data - p_sim| / 0.1048 m, per toss (Acosta et al. 2022).", "",
              "## Parameters", "", "| name | value |", "|---|---|"]
    lines += [f"| {k} | {v} |" for k, v in params.items()]
    if notes:
        lines += ["", notes]
    lines += ["", "![error per toss](error_per_toss.png)", "", "![trajectories](trajectories.png)", ""]
    return "\n".join(lines)
