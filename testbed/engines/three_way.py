"""One ground truth for every candidate: `testbed compare SCENE --engine all`.

The learned comparison runs Drake at the learned law's modulus (1e8 Pa unless the scene
sets one) and `--engine mujoco` at the scene's own (the shipped SDF's 1e9 Pa), so their
figures are errors against different truths. Here the scene is first set to the learned
law's modulus (effects.contact.hydroelastic_modulus = law_modulus), then ONE Drake
hydroelastic run at that modulus is the reference for three candidates from the same
initial state: Drake point contact, the learned closed loop (the twin run of
testbed/compare, gated as usual) and every other registered engine (testbed/engines:
MuJoCo, with contact parameters matched to that same Drake: its model.py follows the
scene's modulus).

Every row's figures come from testbed.compare.metrics.compare_figures against that one
truth run, with the separating-axis depth (SatDepth) for the penetration of all three;
wall times are per simulated second [s], measured in this one process.
Adding an engine adds its row here (testbed.engines.alternatives).
"""

from __future__ import annotations

from testbed import variants
from testbed.compare.metrics import compare_figures
from testbed.engines import alternatives
from testbed.engines.comparison import SatDepth, engine_variant

# the figures of each row (compare_figures' keys; lengths [m], angles [deg], energies [J])
ROW_KEYS = ("diverged", "simulated_s_learned", "position_error_max_m", "final_position_error_max_m",
            "final_angle_error_max_deg", "max_penetration_m", "energy_gain_max_J")


def at_law_modulus(scenario):
    """A copy of `scenario` whose containers are at the learned law's modulus
    (effects.contact.hydroelastic_modulus set), for every engine alike."""
    return variants.derive(scenario, variants.modulus(None))


def check_three_way(scenario) -> None:
    """Raises UnsupportedSceneError before anything runs when an engine cannot run the scene."""
    ground = engine_variant(scenario, "truth")
    for e in alternatives():
        e.check(ground)


def rows(scenario, figures: dict, runs: dict, params: str = "matched", predictor: str | None = None) -> dict:
    """compare.json's `three_way`: {'reference', 'hydroelastic_modulus_Pa', 'wall_per_sim_s_truth',
    '<engine>_version', 'rows': [{'model', ROW_KEYS (simulated_s_learned as 'simulated_s'),
    'wall_per_sim_s', 'speedup_vs_truth'}]} for Drake point, the learned loop and every other
    engine (`params` where it has that set) against runs['truth']. An engine whose contact a
    predictor decides (Engine.learned: MuJoCo + learned) runs `predictor`, the one the learned
    loop's row runs (the spec compare was given), so that every learned row answers with the
    user's model; None: the engine's own default.
    scenario: at the law's modulus (at_law_modulus); figures: the learned twin run's;
    runs: its trajectories ('truth', 'learned', 'point')."""
    h = scenario.plant.time_step
    every = max(1, int(round(figures["record_period_s"] / h)))
    truth = runs["truth"]
    truth_wall = truth.wall_s / max(truth.simulated_s, 1e-12)
    candidates_ = [("Drake point", runs["point"], None), (f"learned ({figures['predictor']})", runs["learned"], None)]
    versions, ground = {}, engine_variant(scenario, "truth")  # = the twins' truth: the scene is at the law's modulus
    for e in alternatives():
        if e.learned and predictor is not None:
            chosen, shown = predictor, figures["predictor"]
        else:
            chosen = params if params in e.param_sets else (e.param_sets[0] if e.param_sets else None)
            shown = chosen
        run = e.run(ground, duration=figures["duration_s"], record_every=every, params=chosen)
        versions[f"{e.name}_version"] = run.summary.get("version", "")
        candidates_.append((f"{e.label} ({shown})" if shown else e.label, run.trajectory, run.summary["wall_per_sim_s"]))
    out = []
    for name, traj, wall in candidates_:
        f = compare_figures(truth, traj, scenario.containers, SatDepth())
        wall = traj.wall_s / max(traj.simulated_s, 1e-12) if wall is None else wall
        row = {"model": name, **{k.replace("_learned", ""): f[k] for k in ROW_KEYS}}
        row.update(wall_per_sim_s=wall, speedup_vs_truth=truth_wall / wall)
        out.append(row)
    return {"reference": f"Drake hydroelastic at {figures['hydroelastic_modulus_Pa']:.0e} Pa (one run)",
            "hydroelastic_modulus_Pa": figures["hydroelastic_modulus_Pa"], "wall_per_sim_s_truth": truth_wall,
            **versions, "rows": out}


def format_table(three: dict) -> list[str]:
    """The three-way table `testbed compare --engine all` prints."""
    head = ("model", "ran [s]", "pos err max [mm]", "final pos [mm]", "final angle [deg]", "max pen [mm]",
            "energy gain [J]", "wall/sim s [s]", "x vs hydroelastic")
    body = [(r["model"] + (" DIVERGED" if r["diverged"] else ""), f"{r['simulated_s']:g}",
             f"{r['position_error_max_m'] * 1e3:.3f}", f"{r['final_position_error_max_m'] * 1e3:.3f}",
             f"{r['final_angle_error_max_deg']:.4f}", f"{r['max_penetration_m'] * 1e3:.3f}",
             f"{r['energy_gain_max_J']:.3g}", f"{r['wall_per_sim_s']:.4f}", f"{r['speedup_vs_truth']:.2f}")
            for r in three["rows"]]
    widths = [max(len(x) for x in col) for col in zip(head, *body)]
    lines = [f"  against one reference: {three['reference']}, wall {three['wall_per_sim_s_truth']:.3f} s per "
             "simulated s; penetration by separating-axis depth for every row"]
    lines += ["  " + "  ".join(x.ljust(w) for x, w in zip(row, widths)).rstrip() for row in (head, *body)]
    return lines
