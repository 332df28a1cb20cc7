"""`compare_scene`: the twin run of one scene and its output directory;
`compare_predictors`: several predictors against one truth run (what validate needs)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from testbed.builder import build_scene
from testbed.compare import artifacts, costs
from testbed.compare.metrics import compare_figures
from testbed.compare.runs import run_variant, variant
from testbed.effects.learned_dynamics.force_law import law_modulus
from testbed.errors import TestbedError
from testbed.records import atomic_directory, steps_per_record, write_json
from testbed.scenario import Scenario, load_scenario, resolve_scene_path


def _load(scene, source=None):
    """(Scenario, source for messages) of a name, path or loaded Scenario (its `source`)."""
    if isinstance(scene, Scenario):
        return scene, source or "<scenario>"
    path = resolve_scene_path(scene)
    return load_scenario(path), path


def truth_accuracy(scenario) -> float | None:
    """The continuous truth's integrator accuracy where the scene is judged against the converged
    rung (scenario.truth.reference "continuous"), else None (its discrete plant)."""
    return scenario.truth.accuracy if scenario.truth.reference == "continuous" else None


def compare_scene(scene, *, predictor: str | None = None, out_dir, duration: float | None = None,
                  with_point: bool = True, replay: bool = True, record_every: int | None = None,
                  source=None, judge=None) -> dict:
    """Runs `scene` (a name, path or Scenario) with Drake's contact (the scene's model),
    with the learned closed loop (`predictor`: "improved", "paper" or a weights path; None:
    the scene's learned_dynamics.predictor if it declares the effect, else "improved") and,
    when `with_point`, with Drake's point contact (for its wall time), from the same
    initial state; writes out_dir/compare.json, trajectories.npz, divergence.png and
    (when `replay`) replay.html atomically, and returns the compare.json figures.
    Raises ScenarioError (bad scene or predictor) before anything is simulated or written.
    source: the file a loaded Scenario came from (named in error messages).
    judge: None, or (figures, directory, runs) -> dict of keys merged into compare.json,
    called once trajectories.npz is in `directory`; runs: {'truth', 'learned'[, 'point']:
    Trajectory} (the verdict: testbed/validation/compare_verdict.py).
    """
    (figures,) = compare_predictors(scene, [predictor], out_dirs=[out_dir], duration=duration,
                                    with_point=with_point, replay=replay, record_every=record_every, source=source,
                                    judge=judge)
    return figures


def compare_predictors(scene, predictors, *, out_dirs, duration: float | None = None, with_point: bool = True,
                       replay: bool = True, record_every: int | None = None, source=None, judge=None) -> list[dict]:
    """compare_scene for each of `predictors`, sharing one truth run (and one point run):
    out_dirs[i] receives predictors[i]'s files. Every scene is built (and so every
    predictor loaded) before anything runs. Returns the figures, in order."""
    scenario, source = _load(scene, source)
    duration = scenario.duration if duration is None else float(duration)
    if not duration > 0:
        raise TestbedError(f"duration: expected a positive number of seconds, got {duration}")
    h = scenario.plant.time_step
    every = record_every or steps_per_record(h)
    learned = [build_scene(variant(scenario, "learned", p), source) for p in predictors]
    truth_scene = build_scene(variant(scenario, "truth"), source, continuous_accuracy=truth_accuracy(scenario))
    point_scene = build_scene(variant(scenario, "point"), source) if with_point else None
    truth = run_variant(None, duration, every, scene=truth_scene)
    point = run_variant(None, duration, every, scene=point_scene) if with_point else None
    out = []
    for scene_l, out_dir in zip(learned, out_dirs):
        effect = scene_l.effects["learned_dynamics"]
        run = run_variant(None, duration, every, scene=scene_l)
        runs = {"truth": truth, "learned": run, **({"point": point} if point else {})}
        figures = {"scene": scenario.name, "predictor": effect.config.predictor,
                   "predictor_kind": getattr(effect.predictor, "kind", effect.config.predictor),
                   "duration_s": duration, "time_step_s": h, "record_period_s": every * h,
                   "hydroelastic_modulus_Pa": law_modulus(scenario),  # every run's containers (runs.variant)
                   "truth_reference": scenario.truth.reference, "truth_accuracy": truth_accuracy(scenario)}
        figures.update(compare_figures(truth, run, scenario.containers, effect.predictor))
        for kind, traj in runs.items():
            figures[f"wall_per_sim_s_{kind}"] = traj.wall_s / max(traj.simulated_s, 1e-12)
        figures["speedup_vs_truth"] = figures["wall_per_sim_s_truth"] / figures["wall_per_sim_s_learned"]
        # how often the model was asked: container pairs the effect watches, pair-steps it predicted
        figures["container_pairs"] = len(effect.pairs)
        figures["pair_steps_learned"] = int(run.costs.get("predict_pairs", 0))
        if run.costs:  # where the learned run's wall time went (testbed/compare/costs.py)
            figures["cost_learned"] = costs.breakdown(run.costs, run.wall_s, int(round(run.simulated_s / h)))
        if point:
            figures["speedup_vs_point"] = figures["wall_per_sim_s_point"] / figures["wall_per_sim_s_learned"]
        figures["stability_max"] = max((r["explicit"] for r in effect.stability), default=0.0)
        figures["learned_dynamics_config"] = dataclasses.asdict(effect.config)
        figures["stability"] = [{**r, "pair": list(r["pair"])} for r in effect.stability]
        _write(out_dir, figures, runs, scenario, replay, judge)
        figures["out_dir"] = str(Path(out_dir))
        out.append(figures)
    return out


def _write(out_dir, figures: dict, runs: dict, scenario, replay: bool, judge=None) -> None:
    with atomic_directory(out_dir) as tmp:
        artifacts.write_series(tmp / "trajectories.npz", runs)
        if judge is not None:
            figures.update(judge(figures, tmp, runs))
        artifacts.plot_divergence(tmp / "divergence.png", runs["truth"], runs["learned"], scenario.name,
                                  figures["predictor"])
        if replay:
            artifacts.write_ghost_replay(tmp / "replay.html", scenario, runs["truth"], runs["learned"])
        write_json(tmp / "compare.json", figures)
