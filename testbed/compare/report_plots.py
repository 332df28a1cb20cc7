"""The plots of a twin run (`testbed compare`), built from trajectories.npz's arrays so that they
read the same at 2 containers and at 1,000:

- divergence_figure: the position error over time of the worst containers (at most WORST_LINES,
  named) with the median and the max over all of them as two more lines; the energy raw,
  E(t) - E(0), and net of the external actors' work, C(t) = E(t) - E(0) - W(t), with the energy
  gate's figure (the largest C(t) beyond the truth's C(t) where positive) marked on its curve;
- error_map_figure: the final position error over the yard's layout, a top view (x-y) of the
  truth's final poses, each container's footprint coloured by its error with a colour bar, the
  worst MAP_LABELS named.

Every legend holds at most MAX_LEGEND entries whatever the number of containers. `series` is a
mapping of trajectories.npz's keys (artifacts.write_series) to arrays; `under` the prefix of the
run under test in it ('learned', 'mujoco', ...). matplotlib is imported inside the functions (Agg
backend, testbed.document.pyplot), never when testbed is imported.
"""

from __future__ import annotations

import warnings

import numpy as np

from testbed.compare.metrics import joules
from testbed.document import pyplot
from testbed.gates.closed_loop import energy_created
from testbed.geometry.rotations import angle_between_quaternions_deg, rotation_from_quaternion

WORST_LINES = 4  # containers named in the error-over-time plot: with the median and the max, 6 legend entries
MAP_LABELS = 5  # containers named on the error map
MAX_LEGEND = 6  # the most entries of any legend


def worst_containers(err: np.ndarray, k: int) -> list[int]:
    """The columns of err (n, m) with the largest value over time, worst first, at most k (a
    non-finite value counts as infinitely bad: a run that blew up)."""
    peak = np.nan_to_num(np.asarray(err, float), nan=np.inf).max(axis=0) if len(err) else np.zeros(err.shape[1])
    return [int(i) for i in np.argsort(-peak, kind="stable")[:k]]


def energy_curves(series, under: str) -> dict:
    """The energy of the run under test and of the truth over the run's records [J]: time,
    raw / raw_truth (E(t) - E(0)), work / work_truth (W(t), the external actors' work; zeros
    without one or where the records cannot give it), net / net_truth (C(t) = raw - W),
    excess (C(t) less the truth's C(t) where positive), gated (max of excess: the energy gate's
    figure, testbed.gates.closed_loop.energy_created), at (its time [s]), counted (whether W
    came from the records), actors (the external actors' names)."""
    t = np.asarray(series[f"{under}_time"], float)
    n = len(t)
    E, E_T = np.asarray(series[f"{under}_energy"], float), np.asarray(series["truth_energy"], float)[:n]
    counted = f"{under}_external_work" in series and "truth_external_work" in series
    W = np.asarray(series[f"{under}_external_work"], float) if counted else np.zeros(n)
    W_T = np.asarray(series["truth_external_work"], float)[:n] if counted else np.zeros(n)
    raw, raw_T = E - E[0], E_T - E_T[0]
    net, net_T = raw - W, raw_T - W_T
    excess = net - np.maximum(0.0, net_T)
    gated = energy_created(E, E_T, (W, W_T) if counted else None)
    at = float(t[int(np.argmax(np.nan_to_num(excess, nan=np.inf)))]) if n else float("nan")
    actors = [str(a) for a in series["external_actors"]] if "external_actors" in series else []
    return {"time": t, "raw": raw, "raw_truth": raw_T, "work": W, "work_truth": W_T, "net": net, "net_truth": net_T,
            "excess": excess, "gated": gated, "at": at, "counted": counted, "actors": actors}


def divergence_figure(series, under: str, title: str, label: str = "learned"):
    """The position error [mm] over time (the WORST_LINES worst containers by their largest
    error, named, and the median and the max over all containers), the raw energy change and
    the energy net of the external actors' work of the run under test and of Drake's [J]."""
    plt = pyplot()
    t = np.asarray(series[f"{under}_time"], float)
    err = np.asarray(series["position_error"], float) * 1e3  # (n, m) [mm]
    names = [str(x) for x in series["names"]]
    m = err.shape[1]
    fig, (ax1, ax2, ax3) = plt.subplots(3, 1, figsize=(8, 9), sharex=True)
    worst = worst_containers(err, WORST_LINES)
    for k in worst:
        ax1.plot(t, err[:, k], lw=1.2, label=names[k])
    if m > 1:
        with warnings.catch_warnings():  # an all-NaN record (a run gone non-finite) has no median
            warnings.simplefilter("ignore", RuntimeWarning)
            ax1.plot(t, np.nanmedian(err, axis=1), color="black", ls="--", lw=1.0, label=f"median of all {m}")
            ax1.plot(t, np.nanmax(err, axis=1), color="black", lw=2.0, alpha=0.45, label=f"max of all {m}")
    shown = f"the {len(worst)} worst of {m} containers" if m > len(worst) else f"each of the {m} container(s)"
    ax1.set_title(f"{title}\nposition error against Drake: {shown}" + (", median and max of all" if m > 1 else ""),
                  fontsize="medium")
    ax1.set_ylabel("position error [mm]")
    ax1.legend(fontsize="small", loc="best")
    e = energy_curves(series, under)
    ax2.plot(t, e["raw"], label=f"{label}: E(t) - E(0)")
    ax2.plot(t, e["raw_truth"], label="Drake: E(t) - E(0)")
    ax2.set_ylabel("raw [J]")
    ax2.set_title("energy change, raw (the external actors' work included)", fontsize="medium")
    ax2.legend(fontsize="small", loc="best")
    ax3.plot(t, e["net"], label=f"{label}: C(t) = E(t) - E(0) - W(t)")
    ax3.plot(t, e["net_truth"], label="Drake: C(t)")
    ax3.plot(t, e["excess"], color="tab:red", ls=":", label=f"{label}'s C(t) beyond Drake's where positive")
    ax3.plot([e["at"]], [e["gated"]], "o", color="tab:red", label=f"energy gate's figure: {joules(e['gated'])} J")
    ax3.set_ylabel("net [J]")
    ax3.set_xlabel("time [s]")
    ax3.set_title(_net_title(e), fontsize="medium")
    ax3.legend(fontsize="small", loc="best")
    fig.tight_layout()
    return fig


def _net_title(e: dict) -> str:
    if not e["counted"]:
        return "energy net of the external work: the records cannot give the work, so W = 0 (net = raw)"
    if not e["actors"]:
        return "energy net of the external work: no external actor in this scene (net = raw)"
    largest = float(np.max(np.abs(np.nan_to_num(e["work"], nan=0.0)), initial=0.0))
    return f"energy net of the work of {', '.join(e['actors'])} (max |W| {joules(largest)} J)"


def final_errors(series, under: str) -> dict:
    """At the last record of the run under test: names (m,), error_mm (m,) the position error,
    angle_deg (m,) the rotation between its orientation and the truth's, p (m, 3) and R (m, 3, 3)
    the truth's poses there."""
    n = len(series[f"{under}_time"])
    q_T = np.asarray(series["truth_q_WB"], float)[n - 1]
    angle = angle_between_quaternions_deg(np.asarray(series[f"{under}_q_WB"], float)[n - 1], q_T)
    with np.errstate(invalid="ignore"):
        R = rotation_from_quaternion(q_T / np.linalg.norm(q_T, axis=-1, keepdims=True))
    return {"names": [str(x) for x in series["names"]], "error_mm": np.asarray(series["position_error"], float)[n - 1] * 1e3,
            "angle_deg": np.asarray(angle, float), "p": np.asarray(series["truth_p_WB"], float)[n - 1], "R": R}


def footprint(p, R, size) -> np.ndarray:
    """(4, 2) the x-y corners of a box at position p (3,) and rotation R (3, 3) whose size is
    (length x, width y, height z) [m]: its body x-y rectangle seen from above."""
    half = 0.5 * np.asarray(size[:2], float)
    local = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]) * half
    return np.asarray(p, float)[:2] + local @ np.asarray(R, float)[:2, :2].T


def error_map_figure(series, under: str, title: str, layout=None):
    """The final position error [mm] over the yard's layout: each container's footprint at the
    truth's final pose, seen from above (x-y), coloured by its error (colour bar), drawn the
    least wrong first so that a stack shows its worst box; the MAP_LABELS worst numbered on the
    map and named, with their error and angle, in the key under it. layout: {'sizes': {name:
    (x, y, z) [m]}, 'welded': [(p (3,), R (3, 3), size)]} (report.layout_of a scene); None: a
    marker per container."""
    from matplotlib.collections import PolyCollection
    from matplotlib.colors import Normalize
    from mpl_toolkits.axes_grid1 import make_axes_locatable

    plt = pyplot()
    f = final_errors(series, under)
    err = np.nan_to_num(f["error_mm"], nan=np.inf)
    finite = err[np.isfinite(err)]
    top = float(finite.max()) if finite.size and finite.max() > 0 else 1.0
    norm, cmap = Normalize(0.0, top), plt.get_cmap("viridis")
    colours = cmap(norm(np.minimum(err, top)))
    order = np.argsort(err, kind="stable")  # the worst drawn last, on top
    sizes = (layout or {}).get("sizes") or {}
    drawn = bool(sizes) and all(name in sizes for name in f["names"])
    welded = [footprint(p, R, s) for p, R, s in (layout or {}).get("welded", ())] if drawn else []
    boxes = [footprint(f["p"][i], f["R"][i], sizes[f["names"][i]]) for i in order] if drawn else []
    corners = np.concatenate(boxes + welded) if drawn else f["p"][:, :2]
    low, high = corners.min(axis=0), corners.max(axis=0)
    pad = 0.05 * max(float(np.max(high - low)), 2.0)
    low, high = low - pad, high + pad
    named = worst_containers(f["error_mm"][None, :], MAP_LABELS)
    aspect = float((high[1] - low[1]) / (high[0] - low[0]))
    height = float(np.clip(7.5 * aspect, 1.8, 7.0))  # [in] the map's, at 7.5 in wide
    key = 0.2 + 0.17 * len(named)  # [in] the key's lines under the map
    fig = plt.figure(figsize=(9, height + 1.2 + key))
    grid = fig.add_gridspec(2, 1, height_ratios=[height, key])
    ax, key_ax = fig.add_subplot(grid[0]), fig.add_subplot(grid[1])
    if drawn:
        if welded:
            ax.add_collection(PolyCollection(welded, facecolors="none", edgecolors="grey", linestyles="dotted"))
        ax.add_collection(PolyCollection(boxes, facecolors=colours[order], edgecolors="black", linewidths=0.4))
    else:
        ax.scatter(f["p"][order, 0], f["p"][order, 1], c=colours[order], s=40, edgecolors="black", linewidths=0.4)
    ax.set_xlim(low[0], high[0])
    ax.set_ylim(low[1], high[1])
    ax.set_aspect("equal", adjustable="box")
    bar = make_axes_locatable(ax).append_axes("right", size="2.5%", pad=0.1)
    fig.colorbar(plt.cm.ScalarMappable(norm=norm, cmap=cmap), cax=bar, label="final position error [mm]")
    seen: dict = {}
    for k, i in enumerate(named, 1):  # a numbered badge on the box (side by side where boxes are stacked)
        spot = tuple(np.round(f["p"][i, :2], 1))
        shift, seen[spot] = 14 * seen.get(spot, 0), seen.get(spot, 0) + 1
        ax.annotate(str(k), f["p"][i, :2], xytext=(shift, 0), textcoords="offset points", ha="center", va="center",
                    fontsize="small", fontweight="bold", bbox={"boxstyle": "circle,pad=0.2", "fc": "white", "ec": "tab:red"})
    key_ax.axis("off")
    key_ax.text(0.0, 1.0, "\n".join(f"{k}  {f['names'][i]}: {f['error_mm'][i]:.3g} mm, {f['angle_deg'][i]:.2g} deg"
                                   for k, i in enumerate(named, 1)),
                transform=key_ax.transAxes, fontsize="small", va="top", family="monospace")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(f"{title}\nfinal position error, top view of Drake's final poses ({len(f['names'])} containers; "
                 f"the {len(named)} worst numbered)", fontsize="medium")
    return fig
