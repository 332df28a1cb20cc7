"""Thin wrappers over compare_candidates (testbed/compare/run_candidates.py): `compare_scene`,
one predictor's twin run and its output directory; `compare_predictors`, several predictors
against one truth run, each predictor's files in its own directory (what the bench's
closed-loop section reads); `compare_engine`, any engine against Drake's truth."""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

from testbed import variants
from testbed.compare.candidates import Candidate, engine_candidates, learned_loop, predictor_for
from testbed.compare.run_candidates import compare_candidates, load_scene, slug
from testbed.engines import engine
from testbed.records import atomic_directory, write_json


def compare_scene(scene, *, predictor: str | None = None, out_dir, duration: float | None = None,
                  with_point: bool = True, replay: bool = True, record_every: int | None = None,
                  source=None, judge=None) -> dict:
    """Runs `scene` (a name, path or Scenario) with Drake's contact (the scene's model), with
    the learned closed loop (`predictor`: "improved", "paper" or a weights path; None: the
    scene's learned_dynamics.predictor if it declares the effect, else "improved") and, when
    `with_point`, with Drake's point contact (for its wall time), from the same initial state;
    writes out_dir (compare_candidates' files) and returns the compare.json figures, with the
    verdict of `judge` (testbed/compare/verdict.judge; None: none). Raises
    ScenarioError (bad scene or predictor) before anything is simulated or written."""
    scenario, source = load_scene(scene, source)
    candidates = [learned_loop(predictor_for(scenario, predictor)), *([Candidate.point()] if with_point else [])]
    return compare_candidates(scenario, candidates, duration=duration, record_every=record_every, out_dir=out_dir,
                              replay=replay, source=source, judge=judge)


def compare_predictors(scene, predictors, *, out_dirs, duration: float | None = None, with_point: bool = True,
                       replay: bool = False, record_every: int | None = None, source=None) -> list[dict]:
    """compare_scene for each of `predictors` against one truth run (and one point run):
    out_dirs[i] receives predictors[i]'s compare.json and trajectories.npz (the truth, it as
    'learned', Drake point). Every predictor is loaded before anything runs. Returns the
    figures, in order (each with `out_dir`). `replay` is not drawn here (compare_scene draws it)."""
    scenario, source = load_scene(scene, source)
    candidates = [learned_loop(predictor_for(scenario, p)) for p in predictors]
    with_point_ = [*candidates, *([Candidate.point()] if with_point else [])]
    with tempfile.TemporaryDirectory(prefix="compare-predictors-") as tmp:
        figures = compare_candidates(scenario, with_point_, duration=duration, record_every=record_every,
                                     out_dir=Path(tmp) / "all", source=source)
        common = {k: v for k, v in figures.items() if k in ("scene", "duration_s", "time_step_s", "record_period_s",
                                                            "hydroelastic_modulus_Pa", "truth_reference",
                                                            "truth_accuracy", "wall_per_sim_s_truth")}
        out = []
        for c, out_dir in zip(candidates, out_dirs):
            f = {**common, **figures["candidates"][c.label]}
            with atomic_directory(out_dir) as d:
                shutil.copy(Path(tmp) / "all" / "judged" / slug(c.label) / "trajectories.npz", d / "trajectories.npz")
                write_json(d / "compare.json", f)
            out.append({**f, "out_dir": str(Path(out_dir))})
    return out


def compare_engine(scene, name: str, *, params: str | None = None, predictor: str | None = None, out_dir=None,
                   duration: float | None = None, with_point: bool = True, replay: bool = False,
                   record_every: int | None = None, time_step: float | None = None, source=None,
                   bare_truth: bool = True) -> dict:
    """Twin run of `scene` (name, path or Scenario): Drake's truth and engine `name` (params:
    one of its param_sets, None: its first; predictor: a learned engine's, None: the scene's or
    the shipped default), with their contact rows compared; compare_candidates' figures (the
    engine's under the standard keys of the run under test). time_step: the plant step [s]
    (None: the scene's). bare_truth: time the truth again without its contact log (its wall
    time alone; compare_candidates' retime_reference). Raises UnsupportedSceneError before
    anything runs."""
    scenario, source = load_scene(scene, source)
    if time_step is not None:
        scenario = variants.derive(scenario, variants.timing(time_step=time_step))
    if engine(name).learned:
        predictor = predictor_for(scenario, predictor)
    return compare_candidates(scenario, engine_candidates(name, params=params, predictor=predictor,
                                                          with_point=with_point),
                              duration=duration, record_every=record_every, contacts=True, out_dir=out_dir,
                              replay=replay, source=source, retime_reference=bare_truth)
