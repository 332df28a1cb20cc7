"""Any engine against Drake's ground truth: `testbed compare SCENE --engine NAME` and the
engine case kind's row (testbed/engines/base.py: the Engine protocol).

Reuses testbed/compare (the learned twin run's machinery): the same Drake variants and
Trajectory records, `compare_figures` for the compare.json figures (the learned compare's,
with the engine named as itself: simulated_s_<name>, drift_m_per_min_<name>, <name>_error,
wall_per_sim_s_<name>; keys_for), the same trajectories.npz (the engine under its name's
prefix), divergence plot and ghost replay (the engine's label in title and legend).
Added: the engine's contact rows (one per body pair per step), against Drake's centre of
pressure `p_W_cop` and normal `n_W` of the same step and pair (contact_log rows, every
`record_every` steps), and the wall time per simulated second of each engine measured in
this one process. Drake runs the scene's own contact parameters (engine_variant).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from testbed import variants
from testbed.bodies.containers import HYDROELASTIC_MODULUS
from testbed.compare import artifacts
from testbed.compare.metrics import compare_figures, error_lines
from testbed.effects.learned_dynamics.force_law import KAPPA_MODULUS
from testbed.engines import engine
from testbed.geometry.boxes import box_box_signed_distance
from testbed.physics import percentile_summary
from testbed.records import atomic_directory, steps_per_record, write_json
from testbed.scenario import Scenario, load_scenario, resolve_scene_path


def keys_for(name: str) -> dict:
    """compare_figures' names for the run under test -> compare.json's for engine `name`."""
    return {"simulated_s_learned": f"simulated_s_{name}", "drift_m_per_min_learned": f"drift_m_per_min_{name}",
            "learned_error": f"{name}_error"}


def drake_modulus(scenario) -> float:
    """[Pa] the containers' hydroelastic modulus in the Drake truth MuJoCo is judged against:
    the scene's effects.contact.hydroelastic_modulus, else the shipped SDF's."""
    contact = scenario.effects.contact
    given = contact.hydroelastic_modulus if contact is not None else None
    return HYDROELASTIC_MODULUS if given is None else float(given)


class SatDepth:
    """The `depth` call compare_figures needs from a predictor, by the separating-axis test
    (testbed/geometry/boxes.py): (n,) penetration [m] of B into A, negative = separated."""

    def depth(self, p_AB, R_AB, *, size_A, size_B):
        p, R = np.asarray(p_AB, float).reshape(-1, 3), np.asarray(R_AB, float).reshape(-1, 3, 3)
        sizes = np.hstack([np.asarray(size_A, float).reshape(-1, 3), np.asarray(size_B, float).reshape(-1, 3)])
        out = np.zeros(len(p))
        unique, inverse = np.unique(sizes, axis=0, return_inverse=True)
        for u, row in enumerate(unique):
            rows = np.flatnonzero(inverse.ravel() == u)
            out[rows] = -box_box_signed_distance(p[rows], R[rows], 0.5 * row[:3], 0.5 * row[3:])
        return out


def judged_at(candidate, scenario):
    """The scene an engine is judged on: a learned engine (`learned`: a predictor decides its
    contact, testbed/engines/mujoco_learned) at the learned law's modulus, as the learned twin
    run and its Drake truth are; any other engine at the scene's own."""
    return variants.derive(scenario, variants.modulus(None)) if getattr(candidate, "learned", False) else scenario


def engine_variant(scenario, kind: str):
    """The scene's dynamics alone (PHYSICS effects, no learned loop) for Drake's kind
    'truth' (its own contact model) or 'point', at the scene's own contact parameters: the
    learned twins (testbed.compare.runs.variant) run at the learned law's modulus (1e8 Pa),
    but an engine is judged against the shipped ground truth (the SDF's modulus, or the
    scene's effects.contact.hydroelastic_modulus), and MuJoCo's matched set follows it."""
    point = [variants.contact("point")] if kind == "point" else []
    return variants.derive(scenario, variants.physics_only(learned=False), *point)


def drake_runs(scenario, duration: float, every: int, source="<scenario>", *, bare_truth=True, with_point=True):
    """Drake's runs of the scene's dynamics alone (engine_variant): {'logged': the truth with
    contact_log every `every` steps (its wall time includes that logging), 'truth': the same
    unlogged (when `bare_truth`), 'point': point contact (when `with_point`)}: EngineRuns."""
    drake, ground = engine("drake"), engine_variant(scenario, "truth")
    out = {"logged": drake.run(ground, duration=duration, record_every=every, contacts=True, source=source)}
    if bare_truth:
        out["truth"] = drake.run(ground, duration=duration, record_every=every, source=source)
    if with_point:
        out["point"] = drake.run(ground, duration=duration, record_every=every, params="point", source=source)
    return out


def centre_of_pressure_in_plane(rows: dict, index) -> np.ndarray:
    """(n, 3) [m] where the line of action of Drake's contact wrench crosses the contact plane
    (through p_W_centroid, normal n_W). contact_log's p_W_cop is the point of that line
    nearest the centroid, which leaves the plane when friction tilts the force: a 2.2 t box
    held by a 24 m/s side wind (f_t/f_n = 0.31) has them 0.12 m apart. MuJoCo's
    force-weighted centroid lies in the plane, so the plane crossing is what it is judged
    against. Rows whose force has no normal part keep p_W_cop."""
    cop, c = rows["p_W_cop"][index], rows["p_W_centroid"][index]
    n, f = rows["n_W"][index], rows["f_W"][index]
    fn = np.einsum("ni,ni->n", f, n)
    ok = fn > 1e-9 * np.maximum(np.linalg.norm(f, axis=1), 1e-300)
    s = np.where(ok, np.einsum("ni,ni->n", c - cop, n) / np.where(ok, fn, 1.0), 0.0)
    return cop + s[:, None] * f


def contact_figures(drake_contacts: dict, other_contacts: dict, name: str) -> dict:
    """Point [m] and normal [deg] errors of engine `name`'s contact rows (`other_contacts`)
    against Drake's centre of pressure (in the contact plane, see
    centre_of_pressure_in_plane) and normal, over the (step, a, b) rows both have."""
    def keyed(t):
        return {(int(s), int(a), int(b)): i for i, (s, a, b) in enumerate(zip(t["step"], t["a"], t["b"]))}

    drake, mj = keyed(drake_contacts), keyed(other_contacts)
    common = [k for k in drake if k in mj]
    steps = {k[0] for k in drake}
    extra = sum(1 for k in mj if k[0] in steps and k not in drake)
    out = {"contact_rows_compared": len(common), f"contact_rows_missing_{name}": len(drake) - len(common),
           f"contact_rows_extra_{name}": extra}
    if not common:
        return out
    i_d = np.array([drake[k] for k in common])
    i_m = np.array([mj[k] for k in common])
    point_err = np.linalg.norm(other_contacts["p_W_cop"][i_m] - centre_of_pressure_in_plane(drake_contacts, i_d), axis=1)
    cos = np.einsum("ni,ni->n", other_contacts["n_W"][i_m], drake_contacts["n_W"][i_d])
    angle = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
    last = np.array([k[0] for k in common]) == max(k[0] for k in common)  # the last compared step
    for name, values in (("contact_point_error", point_err), ("contact_normal_error", angle)):
        unit = "m" if name == "contact_point_error" else "deg"
        for stat, value in percentile_summary(values, (50, 95)).items():
            out[f"{name}_{stat}_{unit}"] = value
        out[f"{name}_final_max_{unit}"] = float(values[last].max())
    return out


def max_penetration(contacts: dict) -> float:
    """[m] the deepest penetration of a run's contact rows (0 without contact)."""
    return float(max(0.0, -contacts["phi"].min())) if len(contacts["phi"]) else 0.0


def compare_engine(scene, name: str, *, params: str | None = None, out_dir=None,
                   duration: float | None = None, with_point: bool = True, bare_truth: bool = True,
                   replay: bool = False, record_every: int | None = None, time_step: float | None = None,
                   source=None) -> dict:
    """Twin run of `scene` (name, path or Scenario): Drake (the scene's contact model, the
    ground truth) and engine `name` (`params`: one of its param_sets; None: its first).
    Returns the compare.json figures (the learned compare's, the engine's named by keys_for,
    plus contact_*, wall_per_sim_s_<name> and hydroelastic_modulus_Pa, Drake's); writes
    out_dir/compare.json, trajectories.npz, divergence.png, the engine's files (and
    replay.html when `replay`) atomically when out_dir is given.
    bare_truth: time Drake again without logging (the truth's wall time); with_point: time
    Drake point contact as well; source: the file a loaded Scenario came from (for messages).
    Raises UnsupportedSceneError before anything runs.
    """
    if isinstance(scene, Scenario):
        scenario, source = scene, source or "<scenario>"
    else:
        source = resolve_scene_path(scene)
        scenario = load_scenario(source)
    candidate = engine(name)
    scenario = judged_at(candidate, scenario)
    candidate.check(scenario)
    params = params or (candidate.param_sets[0] if candidate.param_sets else None)
    if time_step is not None:
        scenario = variants.derive(scenario, variants.timing(time_step=time_step))
    duration = scenario.duration if duration is None else float(duration)
    h = scenario.plant.time_step
    every = record_every or steps_per_record(h)
    run = candidate.run(scenario, duration=duration, record_every=every, params=params, contacts=True, source=source)
    other = run.trajectory
    drake = drake_runs(scenario, duration, every, source, bare_truth=bare_truth, with_point=with_point)
    truth, drake_contacts = drake["logged"].trajectory, drake["logged"].contacts
    learned = getattr(candidate, "learned", False)
    runs = {"truth": truth, "learned" if learned else name: other}  # a learned engine's series as the loop's (its gates)
    walls = {"truth": drake.get("truth", drake["logged"]).summary["wall_per_sim_s"]}
    if with_point:
        runs["point"] = drake["point"].trajectory
        walls["point"] = drake["point"].summary["wall_per_sim_s"]
    figures = {"scene": scenario.name, "engine": name, "params": params,
               f"{name}_version": run.summary.get("version", ""), "duration_s": duration, "time_step_s": h,
               "record_period_s": every * h, "hydroelastic_modulus_Pa": drake_modulus(scenario)}
    compared = compare_figures(truth, other, [c for c in scenario.containers if not c.fixed], SatDepth())
    renamed = keys_for(name)
    figures.update({renamed.get(k, k): v for k, v in compared.items()})
    figures["wall_per_sim_s_truth_logged"] = truth.wall_s / max(truth.simulated_s, 1e-12)
    for kind, value in walls.items():
        figures[f"wall_per_sim_s_{kind}"] = value
    figures[f"wall_per_sim_s_{name}"] = run.summary["wall_per_sim_s"]
    figures["speedup_vs_truth"] = figures["wall_per_sim_s_truth"] / figures[f"wall_per_sim_s_{name}"]
    if with_point:
        figures["speedup_vs_point"] = figures["wall_per_sim_s_point"] / figures[f"wall_per_sim_s_{name}"]
    figures[f"{name}_max_penetration_m"] = max_penetration(run.contacts)
    if learned:  # how often the model was asked (pair-steps), as the learned twin run reports it
        figures["pair_steps_learned"] = int(other.costs.get("predict_pairs", 0))
        figures["cost"] = run.summary.get("cost")
    figures.update(contact_figures(drake_contacts, run.contacts, name))
    if out_dir is not None:
        with atomic_directory(out_dir) as tmp:
            artifacts.write_series(tmp / "trajectories.npz", runs, under_test="learned" if learned else name)
            artifacts.plot_divergence(tmp / "divergence.png", truth, other, scenario.name,
                                      f"{params} contact parameters", label=candidate.label)
            if replay:
                artifacts.write_ghost_replay(tmp / "replay.html", scenario, truth, other, label=name)
            for file, text in run.files.items():
                (tmp / file).write_text(text)
            write_json(tmp / "compare.json", figures)
        figures["out_dir"] = str(Path(out_dir))
    return figures


def format_engine_figures(f: dict) -> str:
    """The few lines `testbed compare SCENE --engine NAME` prints."""
    name = f["engine"]
    label = engine(name).label
    other = ("" if f["hydroelastic_modulus_Pa"] == KAPPA_MODULUS else
             f"; `testbed compare` without --engine runs the learned loop and its Drake truth at the learned law's "
             f"{KAPPA_MODULUS:.0e} Pa: its figures are against another truth")
    what = f"the {f['params']} predictor" if engine(name).learned else f"{f['params']} contact parameters"
    lines = [
        f"scene {f['scene']} in {label} {f[f'{name}_version']} ({what}): "
        f"{'DIVERGED' if f['diverged'] else 'ran'} ({f[f'simulated_s_{name}']:g} of {f['duration_s']:g} s)",
        *error_lines(f, label, f[f"wall_per_sim_s_{name}"]),
        f"  Drake's containers at a hydroelastic modulus of {f['hydroelastic_modulus_Pa']:.0e} Pa (the scene's ground "
        f"truth{other})",
    ]
    if "contact_point_error_median_m" in f:
        lines.append(f"  contact point vs Drake's centre of pressure: median {f['contact_point_error_median_m'] * 1e3:.1f} mm, "
                     f"p95 {f['contact_point_error_p95_m'] * 1e3:.1f} mm, last step {f['contact_point_error_final_max_m'] * 1e3:.1f} mm; "
                     f"normal max {f['contact_normal_error_max_deg']:.3f} deg")
    return "\n".join(lines)


def engine_table_row(scene, name: str, *, params=None, duration: float | None = None,
                     record_every: int | None = None) -> dict:
    """One scene, Drake run once and engine `name` once per parameter set (None: all its
    param_sets), all in this process:
    {'scene', 'duration_s', 'wall_per_sim_s_hydroelastic', 'wall_per_sim_s_point',
     name: {params: figures}} where figures are compare.json's (position, angle,
    penetration, energy, contact point/normal errors, wall_per_sim_s_<name>) and the
    speed-ups against Drake's bare hydroelastic and point runs. For the validate section
    "the engine users would pick instead". Raises UnsupportedSceneError."""
    scenario = scene if isinstance(scene, Scenario) else load_scenario(resolve_scene_path(scene))
    candidate = engine(name)
    scenario = judged_at(candidate, scenario)
    candidate.check(scenario)
    duration = scenario.duration if duration is None else float(duration)
    every = record_every or steps_per_record(scenario.plant.time_step)
    drake = drake_runs(scenario, duration, every)
    truth, drake_contacts = drake["logged"].trajectory, drake["logged"].contacts
    walls = {label: drake[kind].summary["wall_per_sim_s"] for kind, label in (("truth", "hydroelastic"), ("point", "point"))}
    row = {"scene": scenario.name, "duration_s": duration, "time_step_s": scenario.plant.time_step,
           **{f"wall_per_sim_s_{k}": v for k, v in walls.items()}, name: {}}
    for p in (params or candidate.param_sets or (None,)):
        run = candidate.run(scenario, duration=duration, record_every=every, params=p, contacts=True)
        figures = compare_figures(truth, run.trajectory, [c for c in scenario.containers if not c.fixed], SatDepth())
        figures.update(contact_figures(drake_contacts, run.contacts, name))
        wall = run.summary["wall_per_sim_s"]
        figures[f"wall_per_sim_s_{name}"] = wall
        figures["speedup_vs_hydroelastic"] = walls["hydroelastic"] / wall
        figures["speedup_vs_point"] = walls["point"] / wall
        row[name][p] = figures
    return row
