"""The bench report's first screen: one short verdict table, read at a glance.

One row per model: the judged ones first ("judged": those the user named that the testbed did
not ship, run.judged), then the shipped predictors beside them ("reference"), then Drake's point-pair query (the cost reference); columns, in
order (COLUMNS): the verdict's word, the costs in microseconds (per pair asked one pair per
call, per pair batched, and per plant step in the closed loop: the predictor's call, the
median over the scenes benched), then the ratios of the per-pair costs to Drake's point-pair
query measured in the same run, then the gate counts. Drake's row gives its fastest round and
the spread (min-max) of its rounds in this run: the ratios read the fastest. Every number is
bench.json's; nothing here measures.
"""

from __future__ import annotations

import math

from testbed.document import Table, table

JUDGED, REFERENCE = "judged", "reference"
DRAKE = "Drake point-pair query"
NONE = "-"
# (row key, column header), in order: costs [us] first, ratios second, then the gates
COLUMNS = (("label", "predictor"), ("role", "role"), ("verdict", "verdict"),
           ("single_us", "us/pair, one pair per call"), ("batched_us", "us/pair, batched"),
           ("step_us", "us/step in the loop (predictor's call, median of scenes)"),
           ("single_ratio", "one pair per call / Drake point-pair"), ("batched_ratio", "batched / Drake point-pair"),
           ("accuracy", "accuracy gates"), ("in_scene", "in-scene gates"), ("closed", "closed-loop scenes"))


def verdict_word(verdict: str) -> str:
    """'GOOD ENOUGH WITHIN 1 KNOWN LIMITS' of a verdict line (run._verdict): its part before the first colon."""
    return str(verdict).split(":", 1)[0].strip()


def loop_us(entry: dict, part: str = "predictor") -> float | None:
    """The median over the closed-loop scenes of cost_learned's `part`_us_per_step [us], None when none."""
    values = sorted(v for f in entry.get("closed_loop", {}).values()
                    for v in [(f.get("cost_learned") or {}).get(f"{part}_us_per_step")]
                    if v is not None and math.isfinite(v))
    return values[len(values) // 2] if values else None


def order(data: dict) -> list[tuple[str, str]]:
    """(spec, role) of every model: the judged ones first, then the others in leaderboard order."""
    judged = list(data.get("judged") or data["leaderboard"])
    return [(s, JUDGED) for s in judged] + [(s, REFERENCE) for s in data["leaderboard"] if s not in judged]


def drake_figures(data: dict) -> dict:
    """{"best_us", "min_us", "max_us", "rounds"} of Drake's point-pair query in this run (rounds
    0 and min = max = best for a bench.json written before its rounds were kept)."""
    ref = data.get("references", {})
    best = ref["drake_point_pair_set_pose_and_query_s_per_pair"] * 1e6
    each = [v * 1e6 for v in ref.get("drake_point_pair_rounds_s_per_pair") or []]
    return {"best_us": best, "min_us": min(each, default=best), "max_us": max(each, default=best), "rounds": len(each)}


def rows(data: dict) -> list[dict]:
    """The first table as data (COLUMNS' keys; costs in us, None where a figure does not apply),
    one dict per model (order), then Drake's point-pair query with its spread (min_us, max_us, rounds)."""
    out = []
    for spec, role in order(data):
        e = data["predictors"][spec]
        c, acc = e["cost"], e["accuracy"]
        scene_gates = [g for f in e.get("in_scene", {}).values() for g in f.get("gates", [])]
        out.append({"spec": spec, "label": e["label"], "role": role, "verdict": verdict_word(e["verdict"]),
                    "good": bool(e["good_enough"]), "single_us": c["single_s_per_pair"] * 1e6,
                    "batched_us": c["batched_s_per_pair"] * 1e6, "step_us": loop_us(e),
                    "single_ratio": c["single_vs_drake_point"], "batched_ratio": c["batched_vs_drake_point"],
                    "accuracy": (acc["gates_passed"], acc["gates_total"]),
                    "in_scene": (sum(g["passed"] for g in scene_gates), len(scene_gates)),
                    "closed": (sum(f["passed"] for f in e["closed_loop"].values()), len(e["closed_loop"]))})
    drake = drake_figures(data)
    out.append({"spec": None, "label": DRAKE, "role": "cost reference", "verdict": NONE, "single_us": drake["best_us"],
                "batched_us": None, "step_us": None, "single_ratio": 1.0, "batched_ratio": None,
                "accuracy": None, "in_scene": None, "closed": None, **{k: drake[k] for k in ("min_us", "max_us", "rounds")}})
    return out


def number(value, fmt: str = ".3g") -> str:
    """A figure as the table writes it ('-' where it does not apply, 'n/a' when not finite; from
    1000 up in whole units)."""
    if value is None:
        return NONE
    if not math.isfinite(value):
        return "n/a"
    return format(value, ".0f") if abs(value) >= 1000 else format(value, fmt)  # 1030, not 1.03e+03


def cells(row: dict) -> list[str]:
    """A row of rows() as the table's text, in COLUMNS' order (Drake's cost with its spread)."""
    single = number(row["single_us"])
    if row.get("rounds"):
        single += f" (min-max {number(row['min_us'])}-{number(row['max_us'])}, {row['rounds']} rounds)"
    return [row["label"], row["role"], row["verdict"], single, number(row["batched_us"]),
            number(row["step_us"], ".3g"), number(row["single_ratio"], ".2g"), number(row["batched_ratio"], ".2g"),
            _count(row["accuracy"]), _count(row["in_scene"]), _count(row["closed"])]


def _count(passed_of) -> str:
    """'3/4' of (passed, of), '-' for None."""
    return NONE if passed_of is None else f"{passed_of[0]}/{passed_of[1]}"


def verdict_table(data: dict) -> Table:
    """The first screen's table of bench.json `data`."""
    return table([h for _, h in COLUMNS], [cells(r) for r in rows(data)])


def headline_text(data: dict) -> str:
    """The short line above the table: each judged model's verdict word."""
    return " | ".join(f"{r['label']}: {r['verdict']}" for r in rows(data) if r["role"] == JUDGED)


def note(data: dict) -> str:
    """What the table's costs are, in one paragraph below it."""
    ref, drake = data.get("references", {}), drake_figures(data)
    spread = (f"its {drake['rounds']} rounds in this run spread {number(drake['min_us'])}-{number(drake['max_us'])} us"
              if drake["rounds"] else "its rounds were not kept in this bench.json")
    return (f"Costs in microseconds, side by side in this process: per pair asked one pair per call "
            f"({ref.get('single_pairs', '?')} pairs) and batched ({ref.get('batch', '?')} pairs per call), best of "
            f"{ref.get('repeats', '?')} rounds; per plant step: the predictor's call in the closed loop, the median over "
            f"the scenes benched. Drake's point-pair query (pose set, then query) is the reference: its fastest round, "
            f"{number(drake['best_us'])} us/pair, divides the ratios (< 1: cheaper); {spread}. "
            "Verdicts and gates: the lines below, then the sections.")


__all__ = ["COLUMNS", "DRAKE", "REFERENCE", "JUDGED", "cells", "headline_text", "note", "rows", "verdict_table"]
