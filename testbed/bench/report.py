"""The bench's files: bench.json (the data `bench` returns), summary.md and a
self-contained index.html (the first screen's verdict table first: first_screen.py; then the
leaderboard, accuracy with its plot: plots.py, cost, scenes; plots embedded), written together
into a temporary directory renamed into place on success."""

from __future__ import annotations

import json
import math
from pathlib import Path

from testbed.bench import first_screen, plots
from testbed.bench.step_cost import ISSUE_TARGET, WHY
from testbed.bench.yard_budget import budget_section
from testbed.document import Bullets, Figure, Section, Text, Verdict, table, to_html, to_markdown
from testbed.gates.closed_loop import DISCRIMINATION
from testbed.provenance import line as provenance_line
from testbed.records import atomic_directory


def _n(value, scale=1.0, fmt=".3g") -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "n/a"
    return format(value * scale, fmt)


def _set(sets: dict, name: str, key: str):
    """A figure of one accuracy set, None when the set was not judged (no pose of the model's sizes)."""
    return sets.get(name, {}).get(key)


def _leaderboard(data: dict) -> Section:
    rows = []
    for rank, spec in enumerate(data["leaderboard"], 1):
        e = data["predictors"][spec]
        s, c = e["accuracy"]["sets"], e["cost"]
        closed = e["closed_loop"]
        good = ("yes" + (f", within {len(e['known_limits'])} known limits" if e["known_limits"] else "")) \
            if e["good_enough"] else "no"
        rows.append((rank, e["label"], e["kind"], good,
                     f"{e['accuracy']['gates_passed']}/{e['accuracy']['gates_total']}",
                     f"{sum(f['passed'] for f in closed.values())}/{len(closed)}",
                     _n(_set(s, "stacking", "point_median_m"), 100), _n(_set(s, "resting", "point_median_m"), 100),
                     _n(_set(s, "general", "point_p95_m"), 100), _n(_set(s, "stacking", "normal_p95_deg")),
                     _n(c["single_s_per_pair"], 1e6), _n(c["batched_s_per_pair"], 1e6),
                     _n(c["batched_vs_drake_point"], fmt=".2g")))
    return Section("Leaderboard", [
        table(["#", "predictor", "source", "good enough", "accuracy gates", "closed-loop scenes", "stacking point "
               "median [cm]", "resting point median [cm]", "general point p95 [cm]", "stacking normal p95 [deg]",
               "us/pair single", "us/pair batched", "batched / Drake point-pair"], rows),
        Text("Good enough = every accuracy gate of learned_contact/evaluation/gates.py, every in-scene gate "
             "(testbed/gates/in_scene.py) and every closed-loop gate on every scene passes; a model declaring fewer "
             "container sizes is judged on poses and scenes of its sizes (the first screen says which); "
             "'within N known limits' = N of them pass only inside a band pinned around the shipped "
             "predictor's figure, where the target itself is not met (each verdict line lists them). Costs are "
             "measured side by side in this process (best of the rounds)."),
    ], order=1)


def _accuracy(data: dict) -> Section:
    rows = []
    for spec in data["leaderboard"]:
        e = data["predictors"][spec]
        for name, f in e["accuracy"]["sets"].items():
            rows.append((e["label"], name, f["n"], *(_n(f[f"point_{q}_m"], 100) for q in ("median", "p95", "p99")),
                         *(_n(f[f"normal_{q}_deg"]) for q in ("median", "p95", "p99")),
                         _n(f["point_median_m_vs_prior"], fmt=".2f"), _n(f["point_p95_m_vs_prior"], fmt=".2f"),
                         _n(f.get("truth_gap_median_m"), 100), _n(f.get("point_median_m_vs_one_point"), 100)))
    return Section("Accuracy on held-out poses (Drake static hydroelastic labels: the exact centre of pressure)", [
        Text("Sets: stacking and general (the training distributions, unused seeds), outside (stacking beyond the "
             "training ranges), resting (overlap log-uniform 5 um to 0.5 mm, roll and pitch within 0.05 deg: where shipped stacks "
             "sit), resting_wider (yaw within 6 deg, offsets up to 3 m along A's x and 0.6 m across, half exactly "
             "level: where landings and overhangs leave a box). 'vs prior': the figure over the geometric estimate's alone on the same poses (< 1: better). "
             "Truth gap: how far Drake's one-point rule (what its discrete solver applies) lies from the exact centre of "
             "pressure on these poses; 'vs one-point': the predictor's median distance to that second reference."),
        table(["predictor", "set", "poses", "point median [cm]", "p95 [cm]", "p99 [cm]", "normal median [deg]",
               "p95 [deg]", "p99 [deg]", "point median vs prior", "point p95 vs prior", "truth gap median [cm]",
               "point median vs one-point [cm]"], rows),
        plots.figure(data)], order=2)


def _share(total, alone) -> str:
    """The wrapper's share of a call: 1 - model alone / through the bench's wrapper."""
    if total is None or alone is None or not total > 0:
        return "-"
    return f"{max(0.0, 1.0 - alone / total):.0%}"


def _loop(e: dict) -> tuple[str, str, str]:
    """Per step in the closed loop, the median over the scenes benched [us]: the predictor's
    call, the rest of the learned system (state, broad phase, force law), the host's step."""
    parts = {"predictor": [], "learned_system": [], "drake_step": []}
    for f in e["closed_loop"].values():
        cost = f.get("cost_learned") or {}
        for part in parts:
            value = cost.get(f"{part}_us_per_step")
            if value is not None and math.isfinite(value):
                parts[part].append(value)
    return tuple(_n(sorted(v)[len(v) // 2], fmt=".0f") if v else "-" for v in parts.values())


def _cost(data: dict) -> Section:
    ref = data["references"]
    rows = [(data["predictors"][s]["label"], _n(c["first_call_s"], fmt=".3g"), _n(c["single_s_per_pair"], 1e6),
             _n(c["batched_s_per_pair"], 1e6), _n(c["single_vs_drake_point"], fmt=".2g"),
             _n(c["batched_vs_drake_point"], fmt=".2g"), _n(c["single_vs_improved_compiled"], fmt=".2g"),
             _n(c["batched_vs_improved_compiled"], fmt=".2g"))
            for s in data["leaderboard"] for c in [data["predictors"][s]["cost"]]]
    integrator = [(data["predictors"][s]["label"], _n(c.get("model_single_s_per_pair"), 1e6),
                   _n(c.get("model_batched_s_per_pair"), 1e6),
                   f"{_n(c.get('model_single_vs_drake_point'), fmt='.2g')} / "
                   f"{_n(c.get('model_batched_vs_drake_point'), fmt='.2g')}",
                   f"{_n(c.get('wrapper_single_s_per_pair'), 1e6)} / {_n(c.get('wrapper_batched_s_per_pair'), 1e6)}",
                   f"{_share(c['single_s_per_pair'], c.get('model_single_s_per_pair'))} / "
                   f"{_share(c['batched_s_per_pair'], c.get('model_batched_s_per_pair'))}",
                   *_loop(data["predictors"][s]))
                  for s in data["leaderboard"] for c in [data["predictors"][s]["cost"]]]
    return Section("Cost per query", [
        Text(f"One pair per call ({ref['single_pairs']} pairs) and batched ({ref['batch']} pairs per call), best of "
             f"{ref['repeats']} rounds; first call = load + one answer. References in the same run: Drake's "
             f"point-pair query with the pose set, {ref['drake_point_pair_set_pose_and_query_s_per_pair'] * 1e6:.3g} "
             f"us/pair; the shipped improved predictor compiled, {ref['improved_compiled_single_s_per_pair'] * 1e6:.3g} "
             f"us/pair single, {ref['improved_compiled_batched_s_per_pair'] * 1e6:.3g} us/pair batched."),
        table(["predictor", "first call [s]", "us/pair single", "us/pair batched", "single / Drake point",
               "batched / Drake point", "single / improved compiled", "batched / improved compiled"], rows),
        Text("What an integrator pays: the model alone (for a model the testbed did not ship: its own call on "
             "inputs prepared beforehand, onnxruntime's session.run or the Python object's predict, timed side by side "
             "with the full call above), the wrapper's cost per pair (the full call less the model's own: the "
             "per-call bound, input conversion, the bench's checks, depth and clipping) and its share of each call, "
             "and per step in the closed loop (median over the scenes benched): the predictor's call, the rest of "
             "the learned system and the host's (Drake's) step. '-' and 'n/a': a shipped predictor has no wrapper."),
        table(["predictor", "model alone us/pair single", "model alone us/pair batched",
               "model alone / Drake point single / batched", "wrapper us/pair single / batched",
               "wrapper's share single / batched", "in the loop: predictor us/step", "learned system us/step",
               "host step us/step"], integrator)], order=3)


def _scenes(data: dict) -> Section:
    open_rows, closed_rows = [], []
    for spec in data["leaderboard"]:
        e = data["predictors"][spec]
        for scene, f in e["in_scene"].items():
            open_rows.append((e["label"], scene, _n(f["duration_s"], fmt="g"), _n(f["point_error_median_m"], 100),
                              _n(f["point_error_max_m"], 100), _n(f["normal_error_median_deg"]),
                              _n(f["normal_error_max_deg"]), _gates_cell(f.get("gates", []))))
        for scene, f in e["closed_loop"].items():
            closed_rows.append((e["label"], scene, _n(f["duration_s"], fmt="g"), "yes" if f["diverged"] else "no",
                                _n(f["final_position_error_max_m"], 1e3), _n(f["final_angle_error_max_deg"]),
                                _n(f["max_penetration_m"], 1e3), _n(f["speedup_vs_truth"], fmt=".2f"),
                                _gates_cell(f["gates"])))
    return Section("In the shipped scenes", [
        Text("Open loop: Drake hydroelastic contact drives the scene; the predictor is asked at every recorded step "
             "and compared with Drake's centre of pressure and normal; the in-scene gate (testbed/gates/in_scene.py, "
             "the validation scene case's and testbed compare's) bounds the point error's median."),
        table(["predictor", "scene", "simulated [s]", "point median [cm]", "point max [cm]", "normal median [deg]",
               "normal max [deg]", "gates"], open_rows),
        Text("Closed loop: the predictor drives the container-container contact (learned_dynamics) against one Drake "
             "hydroelastic truth run per scene; the gates of the validation's closed-loop section, for every predictor."),
        table(["predictor", "scene", "simulated [s]", "diverged", "final position error [mm]", "final angle error [deg]",
               "max penetration [mm]", "x speed of the truth", "gates"], closed_rows),
        *_discrimination(data)], order=4)


def _discrimination(data: dict) -> list:
    """How much each scene where the contact point decides can tell apart (measured by
    bisection on the shipped predictor: closed_loop.DISCRIMINATION), for the scenes benched."""
    benched = dict.fromkeys(s for e in data["predictors"].values() for s in e["closed_loop"])
    scenes = [s for s in benched if s in DISCRIMINATION]
    if not scenes:
        return []
    return [Text("What a scene can tell apart: the smallest change to the shipped predictor that fails its gates "
                 "(a model passing only the stacks may still be biased by 30 cm: on near-parallel faces the loop "
                 "settles wherever the predicted point sits under the centre of mass):"),
            Bullets(tuple(f"{s}: {DISCRIMINATION[s]}" for s in scenes))]


def _gates_cell(gates: list) -> str:
    """'PASS', or 'FAIL: ' and the failed gates' names."""
    bad = [g["name"] for g in gates if not g["passed"]]
    return "FAIL: " + ", ".join(bad) if bad else ("PASS" if gates else "-")


def size_lines(entry: dict) -> list[str]:
    """What the model declares and what that excludes, one line each (bench.json's "sizes",
    testbed.bench.run.sizes_entry): the declared sizes; for a model declaring fewer than every
    shipped type, the accuracy sets' type pairs and each scene section's skipped and added scenes."""
    z = entry.get("sizes")
    if not z:
        return []
    who = entry["label"]
    if z["every_size"]:
        return [f"{who} declares every shipped container size: {z['text']}"]
    lines = [f"{who} declares {len(z['declared'])} container size(s): {z['text']}; judged within them",
             f"{who}: accuracy sets drawn over {len(z['accuracy_pairs'])} of the {z['accuracy_pairs_of']} ordered "
             f"container type pairs ({', '.join(z['accuracy_pairs']) or 'none: no shipped type, no accuracy set'}), "
             "as many poses per set as for every model"]
    for key, what in (("in_scene", "in-scene (open loop)"), ("closed_loop", "closed loop")):
        part = z[key]
        for why in part["skipped"]:
            lines.append(f"{who}: {what} skipped {why}")
        if part["skipped"]:
            lines.append(f"{who}: {what} run instead: "
                         + (", ".join(part["added"]) if part["added"] else "none (no shipped scene of its sizes)"))
    return lines


def verdict_lines(data: dict) -> list[str]:
    """One verdict line per model: the judged models first, then the others as references."""
    judged = data.get("judged") or list(data["leaderboard"])
    lines = [f"{data['predictors'][s]['label']}: {data['predictors'][s]['verdict']}{_force_source(data['predictors'][s])}"
             for s in judged]
    return lines + [f"reference {data['predictors'][s]['label']}: {data['predictors'][s]['verdict']}"
                    f"{_force_source(data['predictors'][s])}" for s in data["leaderboard"] if s not in judged]


def _force_source(entry: dict) -> str:
    """Which force moves the model's containers in the loop (bench.json's force_source)."""
    source = entry.get("force_source")
    if source == "own":
        return "; force: its own (force_n, stiffness), judged in the force section"
    if source == "testbed":
        return "; force: the testbed's exact field force (the model answers none)"
    return ""


def headline(data: dict) -> tuple[bool, list[str]]:
    """(every judged model good enough, the lines `testbed bench` prints: per model its verdict
    line, the judged models first, then the others as references, each followed, indented, by
    what a model declaring fewer sizes was not judged on). The judged models are those the user
    named that the testbed did not ship (testbed.bench.run.judged); the headline and the exit
    status speak of them."""
    judged = data.get("judged") or list(data["leaderboard"])
    order = judged + [s for s in data["leaderboard"] if s not in judged]
    lines = []
    for spec, line in zip(order, verdict_lines(data)):
        e = data["predictors"][spec]
        lines.append(line)
        lines += [f"  {x}" for x in size_lines(e) if not e.get("sizes", {}).get("every_size", True)]
    return all(data["predictors"][s]["good_enough"] for s in judged), lines


def _declared(data: dict) -> list:
    rows = [x for s in data["leaderboard"] for x in size_lines(data["predictors"][s])]
    return [Text("Container sizes each model declares (its supported_sizes), and what that leaves out (a model is "
                 "judged on the poses and scenes of its sizes):"), Bullets(tuple(rows))] if rows else []


def _force(data: dict) -> list[Section]:
    """The force section (testbed/bench/force.py), when the bench measured it."""
    section = data.get("force")
    if not section:
        return []
    rows = [(name, s["n"], _n(s["exact"]["force_rel_median"], fmt=".2g"), _n(s["exact"]["force_rel_p95"], fmt=".2g"),
             _n(s["exact"]["direction_p95_deg"], fmt=".2g"), s["exact"]["zero_answers"],
             _n(s["exact"]["stiffness_rel_median"], fmt=".2g"), _n(s["exact"]["stiffness_rel_p95"], fmt=".2g"),
             _n(s["foundation"]["force_rel_median"]), _n(s["foundation"]["force_rel_p95"]), s["foundation"]["zero_answers"])
            for name, s in section["sets"].items()]
    for e in data.get("predictors", {}).values():  # a model's own force, on the same sets
        for name, f in (e.get("own_force") or {}).items():
            rows.append((f"{name} ({e['label']}'s own force)", section["sets"].get(name, {}).get("n", "-"),
                         _n(f["force_rel_median"], fmt=".2g"), _n(f["force_rel_p95"], fmt=".2g"),
                         _n(f["direction_p95_deg"], fmt=".2g"), f["zero_answers"], _n(f["stiffness_rel_median"], fmt=".2g"),
                         _n(f["stiffness_rel_p95"], fmt=".2g"), "-", "-", "-"))
    return [Section(f"The contact force the loop applies, against Drake's static force ({section['law']}, "
                    f"{section['modulus_Pa']:.0e} Pa)", [
        Text("A predictor answers a point and a normal; the testbed's law supplies the force that moves the containers, "
             "the same for every predictor that answers no force of its own (a model's own force, rows marked so, drives "
             "its loop instead). Truth: Drake's static hydroelastic force at each pose (exact for its "
             "piecewise-linear field), its stiffness the central difference of that force (+-1 um). Beside it, the former "
             "Winkler foundation on the face overlap (grid 4) on the same poses."),
        table(["set", "poses", "force error median", "p95", "direction p95 [deg]", "0 N where the truth > 1 % of 10 t",
               "stiffness error median", "p95", "foundation: force error median", "p95", "0 N"], rows),
        *_step_cost(section.get("step_cost") or {})], order=2)]


def _step_cost(rows: dict) -> list:
    """What the exact force costs in the step, as ratios to the foundation's (testbed/bench/step_cost.py)."""
    if not rows:
        return []
    return [Text(f"What it costs: the learned step (candidates, predictor, force law) with the exact force over the same step "
                 f"with the foundation, timed side by side (CPU time); target at most {ISSUE_TARGET:g}x. Where it is not met: "
                 f"{WHY}."),
            table(["state", "exact / foundation", "exact [us per step]", "foundation [us per step]", "verdict"],
                  [(name, f"{r['ratio']:.2f}x", f"{r['exact_us']:.1f}", f"{r['foundation_us']:.1f}", r["verdict"])
                   for name, r in rows.items()])]


def sections(data: dict) -> list[Section]:
    """The report of bench.json `data`: the first screen (the short verdict, the verdict table of
    first_screen.py, what its costs are, each model's verdict line, the sizes declared, where it
    was measured), then the leaderboard, accuracy, force, cost, yard budget and scenes."""
    good = all(data["predictors"][s]["good_enough"] for s in (data.get("judged") or data["leaderboard"]))
    head = Section(None, [Verdict(good, first_screen.headline_text(data)), first_screen.verdict_table(data),
                          Text(first_screen.note(data)), Bullets(tuple(verdict_lines(data))), *_declared(data),
                          *([Text(provenance_line(data["provenance"]))] if "provenance" in data else [])], order=0)
    budget = [budget_section(data["yard_budget"], order=3)] if data.get("yard_budget") else []  # after the cost
    return [head, _leaderboard(data), _accuracy(data), *_force(data), _cost(data), *budget, _scenes(data)]


def write_bench(out_dir: Path, data: dict) -> Path:
    """bench.json, summary.md, index.html (and the plot's PNG beside summary.md) in out_dir."""
    parts = sections(data)
    title = f"Predictor bench{' (quick)' if data['quick'] else ''}: {', '.join(p['label'] for p in data['predictors'].values())}"
    with atomic_directory(out_dir) as tmp:
        tmp = Path(tmp)
        (tmp / "bench.json").write_text(json.dumps(data, indent=1, default=float))
        (tmp / "summary.md").write_text(to_markdown(title, parts))
        (tmp / "index.html").write_text(to_html(title, parts))
        for block in (b for s in parts for b in s.blocks if isinstance(b, Figure)):
            (tmp / block.file).write_bytes(block.png)
    return out_dir
