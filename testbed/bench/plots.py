"""The bench report's plot (bench_accuracy_cost.png): accuracy against cost, and the point error
per pose set, every model of the run on both panels (the user's and the shipped references,
in the first screen's order: first_screen.order).

Left: each model's stacking point error p95 [cm] against its cost per pair [us], one pair per
call (open marker) and batched (filled), joined; Drake's point-pair query as the vertical cost
reference, its fastest round dashed and the spread of its rounds in this run shaded. Right: the
point error median per pose set, the sets' names slanted so that they never overlap.
"""

from __future__ import annotations

from testbed.bench.first_screen import REFERENCE, drake_figures, order
from testbed.document import Figure, png, pyplot

FILE = "bench_accuracy_cost.png"


def points(data: dict) -> list[dict]:
    """What the left panel draws, as data: per model with a stacking set its index in order (its colour), label, role,
    (single, batched) cost [us per pair] and stacking point error p95 [cm]."""
    out = []
    for index, (spec, role) in enumerate(order(data)):
        e = data["predictors"][spec]
        stacking = e["accuracy"]["sets"].get("stacking")
        if stacking is None:
            continue
        out.append({"index": index, "label": e["label"], "role": role, "us": (e["cost"]["single_s_per_pair"] * 1e6,
                                                              e["cost"]["batched_s_per_pair"] * 1e6),
                    "p95_cm": stacking["point_p95_m"] * 100})
    return out


def set_names(data: dict) -> list[str]:
    """Every pose set any model was judged on, in the order they first appear."""
    return list(dict.fromkeys(name for spec, _ in order(data) for name in data["predictors"][spec]["accuracy"]["sets"]))


def plain_log(axis) -> None:
    """A log axis labelled at 1, 2 and 5 of each decade in plain numbers ('3', '20', '0.5'), no
    minor labels: matplotlib's default labels every minor tick of a short range in 'a x 10^b'
    form, which overlap."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    axis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
    axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    axis.set_minor_formatter(NullFormatter())


def figure(data: dict) -> Figure:
    """The plot as a report Figure (PNG bytes)."""
    plt = pyplot()
    fig, (cost_ax, sets_ax) = plt.subplots(1, 2, figsize=(11, 4.6))
    for p in points(data):
        i = p["index"]
        dashed = p["role"] == REFERENCE
        who = f"{p['label']}{' (reference)' if dashed else ''}"
        cost_ax.plot(p["us"], [p["p95_cm"]] * 2, ls=":" if dashed else "-", color=f"C{i}", lw=1.2)
        cost_ax.scatter(p["us"][0], p["p95_cm"], s=45, facecolors="none", edgecolors=f"C{i}")
        cost_ax.scatter(p["us"][1], p["p95_cm"], s=45, color=f"C{i}", label=who)
    drake = drake_figures(data)
    if drake["max_us"] > drake["min_us"]:
        cost_ax.axvspan(drake["min_us"], drake["max_us"], color="grey", alpha=0.2,
                        label=f"Drake point-pair, {drake['rounds']} rounds' spread")
    cost_ax.axvline(drake["best_us"], color="grey", ls="--", label=f"Drake point-pair query ({drake['best_us']:.3g} us)")
    cost_ax.set(xscale="log", yscale="log", xlabel="cost per pair [us] (open: one pair per call, filled: batched)",
                ylabel="stacking point error p95 [cm]", title="accuracy against cost")
    cost_ax.legend(fontsize=7)
    for axis in (cost_ax.xaxis, cost_ax.yaxis, sets_ax.yaxis):
        plain_log(axis)
    names = set_names(data)
    for i, (spec, role) in enumerate(order(data)):
        e = data["predictors"][spec]
        sets = e["accuracy"]["sets"]
        xs = [k for k, name in enumerate(names) if name in sets]
        sets_ax.plot(xs, [sets[names[k]]["point_median_m"] * 100 for k in xs], "o" + (":" if role == REFERENCE else "-"),
                     color=f"C{i}", label=e["label"] + (" (reference)" if role == REFERENCE else ""))
    sets_ax.set_xticks(range(len(names)), names, rotation=30, ha="right")
    sets_ax.set(yscale="log", ylabel="point error median [cm]", title="point error per pose set")
    sets_ax.legend(fontsize=7)
    fig.tight_layout()
    return Figure(FILE, "accuracy against cost (Drake's point-pair query as the cost reference), and point error "
                        "per pose set", png(fig))


__all__ = ["FILE", "figure", "points", "set_names"]
