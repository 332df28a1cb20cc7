"""What `testbed compare` runs and prints: the candidate list its options name and the lines
it prints of compare.json (testbed/commands/compare.py keeps its options and exit status).
"""

from __future__ import annotations

from pathlib import Path

from testbed.bodies.containers import HYDROELASTIC_MODULUS
from testbed.compare.candidates import Candidate, all_candidates, engine_candidates, learned_loop
from testbed.compare.costs import breakdown_line, real_time_factor
from testbed.compare.metrics import error_lines, joules
from testbed.compare.report import HTML as REPORT
from testbed.compare.run_candidates import NO_REFERENCE
from testbed.compare.verdict import NOT_JUDGED, headline, verdict_lines
from testbed.effects.learned_dynamics.force_law import KAPPA_MODULUS
from testbed.engines import candidates


def candidate_list(engine_name: str, spec: str, params: str | None, *, no_truth: bool = False) -> list:
    """The candidates `testbed compare` options name: the learned loop and Drake point
    (--engine learned, the default), engine NAME and Drake point (--engine NAME), or every
    engine (--engine all, candidates.all_candidates); Drake point left out with `no_truth`.
    spec: the predictor the learned rows run (candidates.predictor_for: --predictor, else the
    scene's, else the shipped default); params: --params."""
    chosen = candidates().get(engine_name)
    if engine_name == "all":
        out = all_candidates(spec, params or "matched")
    elif chosen.gated:
        out = [learned_loop(spec), Candidate.point()]
    else:
        out = engine_candidates(chosen.name, params=params, predictor=spec)
    return [c for c in out if not (no_truth and c.engine == "drake")]


def compare_lines(f: dict, out=None) -> list[str]:
    """Every line `testbed compare` prints of compare.json `f`: figure_lines, then the
    closed-loop gates and the verdict of a judged run (testbed/compare/verdict.py); out: the
    output directory."""
    judged = f["verdict"] not in (None, NO_REFERENCE)
    lines = figure_lines(f, out, head=headline(f) if judged else "", not_judged=f["verdict"] == NOT_JUDGED)
    return lines + (verdict_lines(f) if judged else [])


def modulus_line(modulus: float, why: str) -> str:
    """The hydroelastic modulus every mode prints (the figures are against a truth at it)."""
    return f"  Drake's containers at a hydroelastic modulus of {modulus:.0e} Pa ({why})"


def figure_lines(f: dict, out=None, *, head: str = "", not_judged: bool = False) -> list[str]:
    """The lines `testbed compare` prints of compare.json `f` before the closed-loop gates' lines:
    what happened (`head`: the verdict's headline of a learned primary), the figures (none of
    the position error "score" when `not_judged`: 0 pair-steps), the table of every candidate
    (--engine all), the output directory `out`; the verdict line itself where no gate judges."""
    if f["verdict"] == NO_REFERENCE:
        return [*_timing_lines(f), *(_output_lines(out) if out is not None else []),
                f"verdict: {NO_REFERENCE} (exit status {f['exit_status']})"]
    primary = candidates()[f["engine"]]
    lines = _learned_lines(f, head, not_judged) if primary.gated else format_engine_figures(f, primary) + truth_lines(f)
    if len(f["candidates"]) > 2:
        lines += format_table(f["table"])
    if out is not None:
        lines += _output_lines(out)
    if f["verdict"] is None:
        lines.append(f"verdict: none (the closed-loop gates judge a learned model in the loop; `--engine all` puts "
                     f"{primary.label} beside it against the same Drake run)")
    return lines


def _output_lines(out) -> list[str]:
    """The output directory and its report (testbed/compare/report.py)."""
    return [f"  output: {out}", f"  report: {Path(out) / REPORT}"]


def _timing_lines(f: dict) -> list[str]:
    """--no-truth: each candidate's run and wall time per simulated second."""
    lines = [f"scene {f['scene']}: {len(f['candidates'])} candidate(s) timed, no reference run (--no-truth); "
             f"containers at a hydroelastic modulus of {f['hydroelastic_modulus_Pa']:.0e} Pa"]
    for label, c in f["candidates"].items():
        ended = f"failed at t = {c['simulated_s']:g} s: {c['error'][:90]}" if c["error"] else "ran"
        factor = real_time_factor(c["wall_per_sim_s"])
        lines.append(f"  {label}: {ended} ({c['simulated_s']:g} of {f['duration_s']:g} s), real-time factor {factor:.2f}x "
                     f"(wall per simulated second {c['wall_per_sim_s']:.4f} s), measured over the whole run, "
                     f"t = 0-{c['simulated_s']:g} s")
    lines.append("  the window includes the start: a yard settles in its first tenths of a second before its islands sleep, "
                 "so a run of a few seconds (--duration) measures the settled cost")
    return lines


def _learned_lines(f: dict, head: str, not_judged: bool) -> list[str]:
    """The learned loop's lines: what happened, its errors and cost, the modulus and the truth."""
    lines = [f"scene {f['scene']} with the {f['predictor']} predictor in the loop: {head} "
             f"({f['simulated_s_learned']:g} of {f['duration_s']:g} s simulated)"]
    errors = error_lines(f, "learned", f["wall_per_sim_s_learned"])
    lines += errors[1:] if not_judged else errors  # no position error "score" for 0 decisions
    cost = breakdown_line(f.get("cost_learned"))
    if cost and not not_judged:
        slower = f.get("speedup_vs_truth", 1.0) < 1.0
        lines.append(f"  the learned run's wall time{' (not faster than Drake hydroelastic here)' if slower else ''}: {cost}")
    if f["hydroelastic_modulus_Pa"] == HYDROELASTIC_MODULUS:
        why = "the shipped containers', in every run of this comparison"
    else:
        why = (f"in every run of this comparison, not the shipped {HYDROELASTIC_MODULUS:.0e} Pa: the learned law's "
               "default, at which it was fitted and judged; the truth is made as soft as the law it is compared with "
               "(docs/commands.md)")
    lines.append(modulus_line(f["hydroelastic_modulus_Pa"], why))
    return lines + truth_lines(f)


def truth_lines(f: dict) -> list[str]:
    """What the reference was: Drake's continuous-time or discrete plant (every mode prints it)."""
    if f.get("truth_reference") == "continuous":
        return [f"  the truth: Drake's continuous-time plant (triangle contact surfaces, exact moments; RungeKutta3 at "
                f"accuracy {f['truth_accuracy']:g}): this scene's discrete answer depends on the contact mesh "
                "(testbed study truth; docs/truth.md)"]
    if "truth_reference" in f:
        return ["  the truth: Drake's discrete plant as the scene sets it (each contact polygon's force at its "
                "centroid; how far that is from a converged answer: testbed study truth)"]
    return []


def format_engine_figures(f: dict, e) -> list[str]:
    """The lines `testbed compare SCENE --engine NAME` prints of compare.json `f` (before the
    verdict lines of a learned engine); e: the engine that ran (f["engine"]'s, resolved once by
    figure_lines)."""
    other = ("" if f["hydroelastic_modulus_Pa"] == KAPPA_MODULUS else
             f"; `testbed compare` without --engine runs the learned loop and its Drake truth at the learned law's "
             f"{KAPPA_MODULUS:.0e} Pa: its figures are against another truth")
    what = f"the {f['predictor']} predictor" if e.learned else f"{f['params']} contact parameters"
    lines = [
        f"scene {f['scene']} in {e.label} {f['version']} ({what}): "
        f"{'DIVERGED' if f['diverged'] else 'ran'} ({f['simulated_s_learned']:g} of {f['duration_s']:g} s)",
        *error_lines(f, e.label, f["wall_per_sim_s_learned"]),
        f"  Drake's containers at a hydroelastic modulus of {f['hydroelastic_modulus_Pa']:.0e} Pa (the scene's ground "
        f"truth{other})",
    ]
    if "contact_point_error_median_m" in f:
        lines.append(f"  contact point vs Drake's centre of pressure: median {f['contact_point_error_median_m'] * 1e3:.1f} mm, "
                     f"p95 {f['contact_point_error_p95_m'] * 1e3:.1f} mm, last step {f['contact_point_error_final_max_m'] * 1e3:.1f} mm; "
                     f"normal max {f['contact_normal_error_max_deg']:.3f} deg")
    return lines


def format_table(table: dict) -> list[str]:
    """The table `testbed compare --engine all` prints (compare.json `table`)."""
    head = ("model", "ran [s]", "pos err max [mm]", "final pos [mm]", "final angle [deg]", "max pen [mm]",
            "energy gain raw [J]", "energy net [J]", "wall/sim s [s]", "x vs hydroelastic", "gates")
    body = [(r["model"] + (" DIVERGED" if r["diverged"] else ""), f"{r['simulated_s']:g}",
             f"{r['position_error_max_m'] * 1e3:.3f}", f"{r['final_position_error_max_m'] * 1e3:.3f}",
             f"{r['final_angle_error_max_deg']:.4f}", f"{r['max_penetration_m'] * 1e3:.3f}",
             joules(r["energy_gain_max_J"]), joules(r.get("energy_created_J")), f"{r['wall_per_sim_s']:.4f}",
             f"{r['speedup_vs_truth']:.2f}",
             r["verdict"] or "-") for r in table["rows"]]
    widths = [max(len(x) for x in col) for col in zip(head, *body)]
    lines = [f"  against one reference: {table['reference']}, wall {table['wall_per_sim_s_truth']:.3f} s per "
             "simulated s; penetration by separating-axis depth for every row; energy net: less the external "
             "actors' work and the truth's own creation (the energy gate's figure); gates: the closed-loop gates' "
             "verdict of each learned row"]
    lines += ["  " + "  ".join(x.ljust(w) for x, w in zip(row, widths)).rstrip() for row in (head, *body)]
    return lines
