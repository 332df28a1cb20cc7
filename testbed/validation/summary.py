"""The report's first screen: the verdict with passes and pinned known limits counted apart,
the limits with their figure and bound, and one row per candidate against Drake.

Candidates are what the suite's records measured: the learned predictors (closed-loop and
scene records, the query study's learned methods), Drake point contact (its closed-loop timing,
its scene runs against the hydroelastic shadow, the query study) and every other engine per
parameter set (the engine records; its own contact query where the query study times one:
Engine.query_method). Nothing here runs a case.
Units: lengths in mm, angles in deg, time per query in us, speed as a ratio of wall times.
"""

from __future__ import annotations

import math

from learned_contact import sources
from testbed.document import Bullets, Section, Text, Verdict, table
from testbed.engines import alternatives
from testbed.gates.closed_loop import (
    EXCLUDED,
    FAMILY_JUDGED,
    FINAL_ANGLE_TOL_DEG,
    FINAL_POSITION_TOL_M,
    FULL_EXTRA,
    FULL_EXTRA_WHY,
    MAX_PENETRATION_M,
    judge as closed_loop_gates,
)
from testbed.validation.cases import ok_records, registry
from testbed.validation.gates import is_known_limit, shown
from testbed.validation.sensitivity import SENSITIVITY_CHECK

POINT = "Drake point contact"
REFERENCE = "Drake hydroelastic (the reference)"
UNITS = ("Units in every table: positions, distances and penetrations in mm, angles in deg, time per query in us, "
         "wall time per simulated second in ms; speed = Drake hydroelastic's wall time / the candidate's (> 1: faster).")


def gate_counts(gates: list[dict]) -> dict:
    """{'passed': gates that pass within their own bound, 'known_limits': gates that pass only
    within a pinned known limit's band, 'failed': the rest} (gates as metrics.json holds them)."""
    pinned = sum(1 for g in gates if g["passed"] and is_known_limit(g))
    failed = sum(1 for g in gates if not g["passed"])
    return {"passed": len(gates) - pinned - failed, "known_limits": pinned, "failed": failed}


def headline(gates: list[dict]) -> str:
    """'120 gates pass, 8 hold only within pinned known limits (listed below).'"""
    c = gate_counts(gates)
    return (f"{c['failed']} of {len(gates)} gates fail; " if c["failed"] else "") + \
        f"{c['passed']} gates pass, {c['known_limits']} hold only within pinned known limits" + \
        (" (listed below)." if c["known_limits"] else ".")


def limit_line(g: dict) -> str:
    """One pinned known limit: its figure, the bound it does not meet, the band it is pinned to."""
    bound = f" against the {shown(g['bound'], g['unit'])} bound" if g.get("bound") is not None else ""
    return f"{g['name']}: {shown(g['value'], g['unit'])}{bound} (pinned band {shown(g['threshold'], g['unit'])})"


def failed_line(g: dict) -> str:
    return f"FAILED {g['name']}: {shown(g['value'], g['unit'])} (threshold {shown(g['threshold'], g['unit'])})"


def head_sections(metrics: dict, records: list[dict]) -> list[Section]:
    """The verdict, the quick-mode studies and the failed gates (order 0), the candidates
    (order 1), the known limits (order 2)."""
    gates = metrics["gates"]
    quick = [q for name, kind in registry().items() if (q := kind.quick(ok_records(records, name)))]
    blocks = [Verdict(metrics["passed"], headline(gates))]
    if quick:
        blocks.append(Text("Quick mode (reduced studies; their figures are indicative): " + "; ".join(quick) + "."))
    failed = [g for g in gates if not g["passed"]]
    if failed:
        blocks.append(Bullets(tuple(failed_line(g) for g in failed)))
    blocks.append(Text(truth_line(records)))
    coverage = coverage_line(records)
    if coverage:
        blocks.append(Text(coverage))
    out = [Section(None, blocks, order=0)]
    rows = candidate_rows(records)
    if rows:
        out.append(Section("Summary: each candidate against Drake", [
            table(["candidate", "contact point vs Drake's centre of pressure, median [mm]: posed pairs / in scenes",
                   "closed loop vs Drake hydroelastic", "speed vs Drake hydroelastic [x]",
                   "cost per query [us]: one pair / batched"], rows),
            Text("Posed pairs: the query study's pose sets against Drake hydroelastic's centre of pressure; in "
                 "scenes: the range over scenes of the median per scene (Drake point contact reports a corner of the "
                 "contact face for face-on-face contact, metres from the centre of pressure of a stack). Speeds: the "
                 "predictors and Drake point contact from the closed-loop runs (containers at the learned law's "
                 "modulus), the other engines from the engine runs, each measured side by side with "
                 "Drake hydroelastic in one process. - : not measured in this suite. " + UNITS)], order=1))
    limits = [g for g in gates if g["passed"] and is_known_limit(g)]
    if limits:
        out.append(Section("Known limits", [
            Text("These gates hold only because their figure stays in the band it is pinned to; the figure is outside "
                 "the gate's own bound (each gate's description in the table of all gates says why):"),
            Bullets(tuple(limit_line(g) for g in limits))], order=2))
    return out


def coverage_line(records: list[dict]) -> str | None:
    """Which scenes the closed loop judged in this run and which shipped scenes with
    container-container contact it left out, with why (testbed.gates.closed_loop: FULL_EXTRA
    left to the full suite, EXCLUDED from every suite); None without closed-loop records."""
    ran = list(dict.fromkeys(r["result"]["scene"] for r in ok_records(records, "closed_loop")))
    if not ran:
        return None
    text = f"The closed loop judged {len(ran)} scene{'s' if len(ran) != 1 else ''} here"
    left = {s: FULL_EXTRA_WHY[s] for s, _ in FULL_EXTRA if s not in ran}
    if left:
        text += "; excluded from this suite, run by the full suite: " + _grouped(left)
    if EXCLUDED:
        text += "; in no suite: " + _grouped(EXCLUDED)
    return text + "."


def _grouped(reasons: dict) -> str:
    """'a, b (why); c (why)': scenes that share a reason named together."""
    groups: dict = {}
    for scene, why in reasons.items():
        groups.setdefault(why, []).append(scene)
    return "; ".join(f"{', '.join(scenes)} ({why})" for why, scenes in groups.items())


def truth_line(records: list[dict]) -> str:
    """Which truth the verdicts are against, how large its own error is, and how it was verified,
    with this run's figures of the one-point rule's distance from it (posed pairs and scenes)."""
    text = ("The truth: Drake hydroelastic, its centre of pressure the exact integral of Drake's pressure field over "
            "Drake's own contact surface (held to a closed form and an independent quadrature to 1e-9 m; the normal "
            "and force are exact under either rule). Drake's discrete solver applies each contact polygon's force "
            "at its centroid (the one-point rule), ")
    gaps = []
    for r in ok_records(records, "learned_gates"):
        f = r["result"].get("figures", {})
        for name in ("stacking", "general", "resting", "resting_wider"):
            if f"{name} truth gap median" in f:
                gaps.append(f"{name} {f[f'{name} truth gap median'] * 1e3:.3g} / {f[f'{name} truth gap p95'] * 1e3:.3g}")
        break
    scene = [s["learned_vs_hydro_truth_gap_median_m"] for r in ok_records(records, "scene")
             if (s := r["result"]).get("learned_vs_hydro_truth_gap_median_m") is not None]
    if gaps:
        text += "which lies " + ", ".join(gaps) + " mm (median / p95) from it on the held-out pose sets"
    else:
        text += "which lies centimetres from it on tilted faces"
    if scene:
        text += f" and {_span(scene, 1e3)} mm (median per scene) in the scenes"
    return text + ("; every centre-of-pressure figure here is a distance to the exact integral. How far the "
                   "simulated motion itself is from a converged answer: `testbed study truth` (docs/truth.md).")


def candidate_rows(records: list[dict]) -> list[tuple]:
    """One row per candidate the records measured: the predictors, Drake point contact,
    every other engine per parameter set, then the reference (Drake hydroelastic)."""
    closed = [r["result"] for r in ok_records(records, "closed_loop")]
    scenes = [r["result"] for r in ok_records(records, "scene")]
    engine = [r["result"] for r in ok_records(records, "engine") if r["result"].get("available")]
    query = [r["result"]["metrics"]["methods"] for r in ok_records(records, "query_study")]
    methods = query[0] if query else {}
    names = list(dict.fromkeys([n for s in closed for n in s["predictors"] if n != SENSITIVITY_CHECK]
                               + [_predictor_of(m) for m in methods if _predictor_of(m)]
                               + ([sources.DEFAULT] if any(_in_scene(s) is not None for s in scenes) else [])))
    rows = [_predictor_row(n, closed, scenes, methods) for n in names]
    point_scenes = [d for s in scenes if (d := _point_disagreement(s)) is not None]
    point_speed = [s["predictors"][n]["wall_per_sim_s_truth"] / s["predictors"][n]["wall_per_sim_s_point"]
                   for s in closed for n in list(s["predictors"])[:1]
                   if _positive(s["predictors"][n].get("wall_per_sim_s_point"))]
    if point_scenes or point_speed or "drake_point" in methods:
        rows.append((POINT, f"{_median_mm(methods.get('drake_point'))} / {_span(point_scenes, 1e3)}",
                     "timed only (its trajectory is not compared)", _span(point_speed, fmt=".2g"),
                     _cost(methods.get("drake_point"))))
    rows += soup_rows(methods)
    for e in alternatives():
        for params in dict.fromkeys(p for s in engine for p in s.get(e.name, {})):
            runs = [(s["scene"], s[e.name][params]) for s in engine if params in s.get(e.name, {})]
            within = [scene for scene, f in runs if _within_bounds(f)]
            missed = [sc for sc, _ in runs if sc not in within]
            query = methods.get(e.query_method) if e.query_method else None
            rows.append((f"{e.label} ({params})",
                         f"{_median_mm(query)} / {_span([f.get('contact_point_error_median_m') for _, f in runs], 1e3)}",
                         f"within the closed-loop bounds on {len(within)} of {len(runs)} scenes (not gated)"
                         + (f"; not on {', '.join(missed)}" if 0 < len(missed) <= 3 else ""),
                         _span([f["speedup_vs_hydroelastic"] for _, f in runs], fmt=".2g"), _cost(query)))
    if rows and "drake_hydro_cc" in methods:
        rows.append((REFERENCE, "0 / 0", "the ground truth", "1", _cost(methods["drake_hydro_cc"])))
    return rows


def soup_rows(methods: dict) -> list[tuple]:
    """Polygon soup, the paper's baseline (collision of triangle meshes: the paper's RAPID, here
    FCL), at the coarsest and the finest mesh the query study timed: its contact point is
    estimated from the colliding triangles, so its accuracy is bounded by their size."""
    soups = sorted((int(m["N"]), name) for name, m in methods.items()
                   if name.startswith("soup_N") and m.get("N") is not None and m.get("available", True))
    picked = dict.fromkeys([soups[0], soups[-1]]) if soups else {}
    return [(f"polygon soup, {12 * n * n:,} triangles per box (triangle meshes, FCL; the paper's baseline)",
             f"{_median_mm(methods[name])} / -", "a query only (not a simulator)", "-", _cost(methods[name]))
            for n, name in picked]


def _predictor_of(method: str) -> str | None:
    """The predictor a query-study learned method times ('improved_single' -> 'improved',
    'paper_mlp_batched' -> 'paper', 'bench_mine_single' -> 'mine'), or None."""
    for suffix in ("_single", "_batched"):
        if method.endswith(suffix):
            stem = method[: -len(suffix)]
            if stem.startswith("bench_"):
                return stem[len("bench_"):]
            return {"improved": "improved", "paper_mlp": "paper"}.get(stem)
    return None


def _method_prefix(name: str) -> str:
    return {"improved": "improved", "paper": "paper_mlp"}.get(name, f"bench_{sources.label(name)}")


def _in_scene(s: dict):
    """The shipped predictor's in-scene point error median [m] of a scene record, or None."""
    return s.get("learned_vs_hydro_point_error_median_m")


def _predictor_row(name: str, closed: list[dict], scenes: list[dict], methods: dict) -> tuple:
    label = sources.label(name)
    shown_name = label + (" (gated)" if name == sources.DEFAULT else " (reported, not gated)")
    prefix = _method_prefix(name)
    in_scene = [v for s in scenes if (v := _in_scene(s)) is not None] if name == sources.DEFAULT else []
    runs = [(s, s["predictors"][name]) for s in closed if name in s["predictors"]]
    speed = [f["speedup_vs_truth"] for _, f in runs if not f["diverged"] and _positive(f.get("speedup_vs_truth"))]
    single, batched = methods.get(f"{prefix}_single"), methods.get(f"{prefix}_batched")
    return (shown_name, f"{_median_mm(single or batched)} / {_span(in_scene, 1e3)}", _closed_verdict(runs),
            _span(speed, fmt=".2g") + (" (runs that did not diverge)" if speed and len(speed) < len(runs) else ""),
            f"{_time(single)} / {_time(batched)}")


def _closed_verdict(runs) -> str:
    """'holds 11 of 12 scenes within the gates, 1 only within pinned known limits; diverges on 0'."""
    if not runs:
        return "-"
    held, pinned, by_family, diverged = [], [], [], []
    for s, f in runs:
        gates = closed_loop_gates(s, f, "")
        if f["diverged"]:
            diverged.append(s["scene"])
        if gates and all(g.passed for g in gates):
            (pinned if any(is_known_limit(g.to_dict()) for g in gates) else
             by_family if s["scene"] in FAMILY_JUDGED else held).append(s["scene"])
    text = f"within the gates on {len(held)} of {len(runs)} scenes"
    if by_family:
        text += f", {len(by_family)} more within their physical gates, the final pose left to a family ({', '.join(by_family)})"
    if pinned:
        text += f", {len(pinned)} more only within pinned known limits ({', '.join(pinned)})"
    return text + f"; diverges on {len(diverged)}" + (f" ({', '.join(diverged)})" if 0 < len(diverged) <= 3 else "")


def _within_bounds(f: dict) -> bool:
    """An engine's run within the closed-loop gates' bounds: final position and angle, penetration."""
    figures = (f.get("final_position_error_max_m"), f.get("final_angle_error_max_deg"), f.get("max_penetration_m"))
    bounds = (FINAL_POSITION_TOL_M, FINAL_ANGLE_TOL_DEG, MAX_PENETRATION_M)
    return not f.get("diverged") and all(_finite(v) and v <= b for v, b in zip(figures, bounds))


def _point_disagreement(s: dict):
    """Median distance [m] between Drake point contact's and hydroelastic's contact point in a
    scene run (one model driving, the other as its shadow), or None."""
    models = {s.get("contact_model"), s.get("shadow_model")}
    return s.get("shadow_cop_distance_median_m") if models == {"point", "hydroelastic"} else None


def _finite(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _positive(v) -> bool:
    return _finite(v) and v > 0


def _span(values, scale: float = 1.0, fmt: str = ".3g") -> str:
    """'low-high' (or one value) of the finite values times scale; '-' when there are none."""
    values = [v * scale for v in values if _finite(v)]
    if not values:
        return "-"
    low, high = _number(min(values), fmt), _number(max(values), fmt)
    return low if low == high else f"{low}-{high}"


def _number(value: float, fmt: str) -> str:
    """value in `fmt`, but whole digits (no exponent) from the digits `fmt` keeps up: 1430, 150."""
    digits = int(fmt.strip(".g") or 6)
    return f"{value:.0f}" if abs(value) >= 10 ** (digits - 1) else format(value, fmt)


def _median_mm(method) -> str:
    if not method or not method.get("available", True):
        return "-"
    return _span([method["all"]["point_error_m"]["median"]], 1e3)


def _time(method) -> str:
    if not method or not method.get("available", True):
        return "-"
    return _span([method["all"]["time_us"]["median"]])


def _cost(method) -> str:
    """A method with one way of calling: its median time per query [us] (no batched form)."""
    return f"{_time(method)} / -"
