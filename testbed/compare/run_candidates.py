"""compare_candidates: one reference run, every candidate from the same initial state, one
compare.json. Every `testbed compare` mode and validate's engine and closed-loop case kinds
build a list of candidates (testbed/compare/candidates.py) and call it.

The scene: at the learned law's modulus (variants.modulus(None): 1e8 Pa unless the scene sets
one) when a candidate is learned or gated, so that the learned law is compared with a truth as
soft as itself; else at the scene's own (the shipped SDF's 1e9 Pa). Every run keeps the
scene's PHYSICS effects alone (no recorder, observer or viewer: its wall time is the
dynamics'); only learned and gated candidates keep the scene's learned_dynamics config.

The reference: Drake's run of the scene's own contact model (`reference_run`), the
continuous-time plant where the scene's truth.reference is "continuous"; with `contacts`, its
contact log every record (the figures' run; its wall time is then taken from a second, unlogged
run of the same reference unless retime_reference is False: the log is not the dynamics' cost).

The figures of one candidate (compare.json `candidates[label]`) carry the standard keys of the
run under test whatever engine ran it: compare_figures' (testbed/compare/metrics.py:
simulated_s_learned, drift_m_per_min_learned, learned_error, ...), wall_per_sim_s_learned
(its wall time per simulated second [s]), wall_per_sim_s_truth / _point and the speed-ups,
and for a learned or gated one pair_steps_learned and the closed-loop gates' verdict (the
`judge` its caller passes: testbed/compare/verdict.judge). Penetration is the separating-axis depth for
every candidate (SatDepth).
"""

from __future__ import annotations

import dataclasses
import re
import tempfile
from pathlib import Path

import numpy as np

from testbed import variants
from testbed.bodies.containers import HYDROELASTIC_MODULUS
from testbed.builder import build_scene
from testbed.compare import artifacts, costs
from testbed.compare.contact_figures import SatDepth, contact_figures, max_penetration
from testbed.compare.external_work import energy_figures, external_work, power_laws
from testbed.compare.in_scene import in_scene_figures
from testbed.compare.metrics import compare_figures
from testbed.compare.report import layout_of, write_report
from testbed.errors import TestbedError
from testbed.records import atomic_directory, steps_per_record, write_json
from testbed.scenario import Scenario, load_scenario, resolve_scene_path, validate_scenario
from testbed.simulation import record_run

NO_REFERENCE = "not judged (no reference run)"
# what the learned engines report of their loop, copied into a candidate's figures where present
SUMMARY_KEYS = ("predictor", "predictor_kind", "container_pairs", "cost", "stability_max",
                "learned_dynamics_config", "stability")
# the figures of each row of compare.json's `table` (lengths [m], angles [deg], energies [J])
TABLE_KEYS = ("diverged", "simulated_s_learned", "position_error_max_m", "final_position_error_max_m",
              "final_angle_error_max_deg", "max_penetration_m", "energy_gain_max_J")


def load_scene(scene, source=None):
    """(Scenario, source for messages) of a name, path or loaded Scenario (its `source`)."""
    if isinstance(scene, Scenario):
        return scene, source or "<scenario>"
    path = resolve_scene_path(scene)
    return load_scenario(path), path


def truth_accuracy(scenario) -> float | None:
    """The continuous truth's integrator accuracy where the scene is judged against the converged
    rung (scenario.truth.reference "continuous"), else None (its discrete plant)."""
    return scenario.truth.accuracy if scenario.truth.reference == "continuous" else None


@dataclasses.dataclass(frozen=True)
class RunScenes:
    """Every scene one comparison runs, derived from the caller's scenario in one place
    (testbed.variants) before anything runs.

    scene: the scenario at the modulus every run shares (the learned law's when a candidate is
    learned or gated, else the scene's own); runs: label -> the scene that candidate runs
    (PHYSICS effects; the learned_dynamics config for a judged one); loops: label -> a judged
    candidate's run scene with its predictor's learned loop on (what validate_scenario checks);
    reference: Drake's truth (learned loop off; its contact log every `every` steps with
    `contacts`); bare: the same without the log (timed alone), None without `contacts`."""

    scene: Scenario
    runs: dict
    loops: dict
    reference: Scenario
    bare: Scenario | None
    every: int

    @property
    def modulus(self) -> float:
        """[Pa] the containers' hydroelastic modulus in every run."""
        contact = self.scene.effects.contact
        given = contact.hydroelastic_modulus if contact is not None else None
        return HYDROELASTIC_MODULUS if given is None else float(given)


def run_scenes(scenario, candidates, *, contacts: bool = False, record_every: int | None = None) -> RunScenes:
    """The scenes compare_candidates runs (RunScenes) for `candidates` (their labels unique:
    ValueError), recorded every `record_every` plant steps (None: every 10 ms)."""
    labels = [c.label for c in candidates]
    if len(set(labels)) != len(labels):
        raise ValueError(f"candidate labels must be unique, got {labels}")
    judged = any(c.judged for c in candidates)
    scene = variants.derive(scenario, variants.modulus(None)) if judged else scenario
    every = record_every or steps_per_record(scene.plant.time_step)
    runs = {c.label: variants.derive(scene, variants.physics_only(learned=c.judged)) for c in candidates}
    loops = {c.label: variants.derive(runs[c.label], variants.learned_loop(c.predictor)) for c in candidates if c.judged}
    bare = variants.derive(scene, variants.physics_only(learned=False))
    reference = variants.derive(bare, variants.log_contacts(every)) if contacts else bare
    return RunScenes(scene, runs, loops, reference, bare if contacts else None, every)


def primary_of(candidates):
    """The candidate compare.json's top level speaks for: the first learned or gated one, else
    the first that is not Drake's own contact, else the first."""
    return next((c for c in candidates if c.judged), next((c for c in candidates if c.engine != "drake"), candidates[0]))


def reference_run(scene, duration: float, every: int, source="<scenario>"):
    """(Trajectory, contact rows or None) of Drake's truth: the built reference `scene`
    (RunScenes.reference or .bare; the continuous-time plant where its truth.reference is
    "continuous"), recorded every `every` plant steps for `duration` [s]; the contact rows where
    the scene logs its contact."""
    built = build_scene(scene, source, continuous_accuracy=truth_accuracy(scene))
    trajectory = record_run(built, duration, every)
    log = built.effects.get("contact_log")
    return trajectory, (log.logger.tables()["contacts"] if log is not None else None)


def check_candidates(scenes: RunScenes, candidates, source="<scenario>") -> None:
    """Before anything runs: every candidate's engine accepts its scene (UnsupportedSceneError)
    and every predictor loads (ScenarioError naming effects.learned_dynamics.predictor)."""
    for c in candidates:
        c.spec.check(scenes.runs[c.label])
        if c.judged:
            validate_scenario(scenes.loops[c.label], source)


def compare_candidates(scenario, candidates, *, reference: str | None = "truth", duration: float | None = None,
                       record_every: int | None = None, contacts: bool = False, out_dir=None, replay: bool = False,
                       source="<scenario>", retime_reference: bool = True, judge=None, in_scene: bool = False,
                       report: bool = False) -> dict:
    """Runs the reference (None: none) once, then each of `candidates` (Candidate) from the same
    initial state of `scenario` (a Scenario: at its modulus per run_scenes) for `duration` [s]
    (None: the scene's), recorded every `record_every` plant steps (None: every 10 ms); with
    `contacts`, the reference logs its contact and every candidate not stepped by Drake is
    judged on its contact rows too, and (`retime_reference`) the reference is simulated once more
    without its log, for its wall time alone (wall_per_sim_s_truth; the logged run's:
    wall_per_sim_s_truth_logged). Writes out_dir (when given) atomically: compare.json,
    trajectories.npz (the truth and every candidate, artifacts.write_series), divergence.png and
    (with `replay`) replay.html of the primary candidate, the engines' own files, and per judged
    candidate judged/<slug>/trajectories.npz (the truth, it as 'learned', Drake point: what the
    closed-loop gates read). Returns compare.json's dict: the common keys, the primary's figures
    and verdict flattened, `candidates` {label: figures} and `table` (one row per candidate).
    judge: (figures, directory) -> the verdict keys of one judged candidate, whose directory holds
    its judged/<slug>/trajectories.npz: testbed.compare.verdict.judge, the closed-loop
    gates (None: no verdict; validate's case kinds judge the series in their own case).
    in_scene: every judged candidate's predictor is also asked beside one more Drake hydroelastic
    run of the scene as the caller gave it, not at the comparison's modulus (testbed.compare.in_scene:
    the bench's in-scene figures, the same run the bench makes of that scene); its in-scene gates
    join the verdict (`testbed compare` sets it; validate's case kinds judge in-scene in their own case).
    report: out_dir also gets report.html and report.md (testbed/compare/report.py) with the PNGs they
    show (`testbed compare` sets it).
    Raises ScenarioError / UnsupportedSceneError before anything runs or is written."""
    if not candidates:
        raise ValueError("compare_candidates: no candidates")
    if reference not in ("truth", None):
        raise ValueError(f"compare_candidates: reference {reference!r}: expected 'truth' or None")
    scenes = run_scenes(scenario, candidates, contacts=contacts and reference is not None, record_every=record_every)
    as_given, scenario, every = scenario, scenes.scene, scenes.every  # as_given: the in-scene run's scene
    duration = scenario.duration if duration is None else float(duration)
    if not duration > 0:
        raise TestbedError(f"duration: expected a positive number of seconds, got {duration}")
    check_candidates(scenes, candidates, source)
    h = scenario.plant.time_step
    common = {"scene": scenario.name, "duration_s": duration, "time_step_s": h, "record_period_s": every * h,
              "hydroelastic_modulus_Pa": scenes.modulus}
    truth = rows = None
    if reference is not None:
        truth, rows = reference_run(scenes.reference, duration, every, source)
        wall = truth.wall_s / max(truth.simulated_s, 1e-12)
        common.update(truth_reference=scenario.truth.reference, truth_accuracy=truth_accuracy(scenario),
                      wall_per_sim_s_truth=wall)
        if scenes.bare is not None and retime_reference:  # the log costs 1.2-1.7x the dynamics (two_stack, measured): time it bare
            bare, _ = reference_run(scenes.bare, duration, every, source)
            common.update(wall_per_sim_s_truth=bare.wall_s / max(bare.simulated_s, 1e-12), wall_per_sim_s_truth_logged=wall)
    runs = {}
    for c in candidates:
        with_rows = contacts and reference is not None and not c.spec.drake_hosted
        runs[c.label] = c.spec.run(scenes.runs[c.label], duration=duration, record_every=every, params=c.run_params,
                                   predictor=c.predictor, contacts=with_rows, source=source)
    primary = primary_of(candidates)
    if reference is None:
        figures = {**common, "primary": primary.label, "verdict": NO_REFERENCE, "exit_status": 0,
                   "candidates": {c.label: timing_figures(c, runs[c.label]) for c in candidates}}
        if out_dir is not None:
            _write_unjudged(out_dir, figures, runs, report)
        return figures
    point = next((runs[c.label] for c in candidates if c.engine == "drake" and c.params == "point"), None)
    per = {c.label: candidate_figures(c, runs[c.label], truth, rows, point, scenario.containers, common)
           for c in candidates}
    laws = power_laws(scenario)  # the external actors' work: the energy net of it, for every candidate
    truth_work = None if laws is None else external_work(laws, truth)
    for c in candidates:
        per[c.label].update(energy_figures(laws, truth, runs[c.label].trajectory, truth_work))
    with (atomic_directory(out_dir) if out_dir is not None else tempfile.TemporaryDirectory(prefix="compare-")) as tmp:
        tmp = Path(tmp)
        asked: dict = {}  # predictor spec -> its in-scene figures
        for c in candidates:
            if c.judged:
                spec = per[c.label].get("predictor") or c.predictor
                if in_scene and spec and (c.spec.learned or c.spec.gated):
                    if spec not in asked:  # one open-loop run per predictor, shared by its rows
                        asked[spec] = in_scene_figures(as_given, spec, duration)
                    per[c.label]["in_scene"] = asked[spec]
                _judge(c, per[c.label], common, tmp, truth, runs[c.label], point, judge, scenario)
        figures = {**common, **per[primary.label], "primary": primary.label, "candidates": per,
                   "table": table(per, common)}
        if "verdict" not in figures:  # no closed-loop verdict: nothing decides the exit status
            figures.update(verdict=None, exit_status=0)
        if out_dir is not None:
            _write(tmp, scenario, figures, truth, runs, candidates, primary, replay, report)
    if out_dir is not None:
        figures["out_dir"] = str(Path(out_dir))
    return figures


def candidate_figures(candidate, run, truth, truth_rows, point, containers, common: dict) -> dict:
    """One candidate's figures (the standard keys, see the module doc) against `truth`
    (Trajectory; truth_rows: its contact rows or None); point: Drake point's EngineRun or None;
    containers: all the scene's ContainerSpecs."""
    traj = run.trajectory
    f = {"engine": candidate.engine, "params": candidate.run_params, "label": candidate.label,
         "version": run.summary.get("version", "")}
    f.update(compare_figures(truth, traj, containers, SatDepth()))
    wall = run.summary["wall_per_sim_s"]
    f["wall_per_sim_s_learned"] = wall
    f["wall_per_sim_s_truth"] = common["wall_per_sim_s_truth"]
    f["speedup_vs_truth"] = common["wall_per_sim_s_truth"] / wall
    if point is not None:
        f["wall_per_sim_s_point"] = point.summary["wall_per_sim_s"]
        f["speedup_vs_point"] = f["wall_per_sim_s_point"] / wall
    if candidate.judged:  # how often the model was asked: pair-steps it predicted
        f["pair_steps_learned"] = int(traj.costs.get("predict_pairs", 0))
        f.update({k: run.summary[k] for k in SUMMARY_KEYS if k in run.summary})
        if candidate.spec.drake_hosted and traj.costs:  # where the learned run's wall time went (costs.py)
            f["cost_learned"] = costs.breakdown(traj.costs, traj.wall_s, int(round(traj.simulated_s / common["time_step_s"])))
    if run.contacts is not None and truth_rows is not None:
        f["contact_rows_max_penetration_m"] = max_penetration(run.contacts)
        f.update(contact_figures(truth_rows, run.contacts))
    return f


def timing_figures(candidate, run) -> dict:
    """A candidate's figures without a reference: its run's length, error and wall time, and
    the scalars of its engine's summary."""
    t = run.trajectory
    scalars = {k: v for k, v in run.summary.items() if isinstance(v, (int, float, str, bool)) or v is None}
    return {"engine": candidate.engine, "params": candidate.run_params, "label": candidate.label,
            "predictor": candidate.predictor, "simulated_s": float(t.simulated_s), "error": t.error,
            "wall_per_sim_s": run.summary["wall_per_sim_s"], "summary": scalars}


def table(per: dict, common: dict) -> dict:
    """compare.json's `table`: every candidate against the one reference, a row each:
    {'model': label, TABLE_KEYS (simulated_s_learned as 'simulated_s'), 'energy_created_J' and
    'external_work_max_J' (the energy net of the external actors' work: external_work.energy_figures),
    'wall_per_sim_s', 'speedup_vs_truth', 'verdict' (None where not judged)}."""
    rows = [{"model": label, **{k.replace("_learned", ""): f[k] for k in TABLE_KEYS},
             "energy_created_J": f.get("energy_created_J"), "external_work_max_J": f.get("external_work_max_J"),
             "wall_per_sim_s": f["wall_per_sim_s_learned"], "speedup_vs_truth": f["speedup_vs_truth"],
             "verdict": f.get("verdict")} for label, f in per.items()]
    return {"reference": f"Drake hydroelastic at {common['hydroelastic_modulus_Pa']:.0e} Pa (one run)",
            "hydroelastic_modulus_Pa": common["hydroelastic_modulus_Pa"],
            "wall_per_sim_s_truth": common["wall_per_sim_s_truth"], "rows": rows}


def slug(label: str) -> str:
    """A directory name for a candidate label: 'learned (improved)' -> 'learned_improved'."""
    return re.sub(r"[^A-Za-z0-9.+-]+", "_", label).strip("_") or "candidate"


def _judge(candidate, f: dict, common: dict, tmp: Path, truth, run, point, judge, scenario=None) -> None:
    """A judged candidate's series as the run under test in tmp/judged/<slug>/trajectories.npz
    (what the closed-loop gates read), and `judge`'s verdict on it merged into its figures `f`."""
    directory = tmp / "judged" / slug(candidate.label)
    directory.mkdir(parents=True)
    series = {"truth": truth, "learned": run.trajectory, **({"point": point.trajectory} if point else {})}
    artifacts.write_series(directory / "trajectories.npz", series, scenario=scenario)
    if judge is not None:
        f.update(judge({**common, **f}, directory))


def series_keys(candidates) -> dict:
    """label -> the candidate's prefix in trajectories.npz: 'point' (Drake point), 'learned'
    (the learned loop), else the engine's name; a repeated one gains _2, _3, ..."""
    out, used = {}, {"truth"}
    for c in candidates:
        base = "point" if (c.engine, c.params) == ("drake", "point") else ("learned" if c.gated else c.engine)
        key, k = base, 2
        while key in used:
            key, k = f"{base}_{k}", k + 1
        used.add(key)
        out[c.label] = key
    return out


def _write(tmp: Path, scenario, figures: dict, truth, runs: dict, candidates, primary, replay: bool,
           report: bool = False) -> None:
    keys = series_keys(candidates)
    series = {"truth": truth, **{keys[c.label]: runs[c.label].trajectory for c in candidates}}
    artifacts.write_series(tmp / "trajectories.npz", series, under_test=keys[primary.label], scenario=scenario)
    under = runs[primary.label].trajectory
    what = (f"{figures['predictor']}" if primary.judged and "predictor" in figures else
            f"{primary.run_params} contact parameters")
    label = "learned" if primary.gated else primary.spec.label
    if replay:
        artifacts.write_ghost_replay(tmp / "replay.html", scenario, truth, under,
                                     label="learned" if primary.gated else primary.engine)
    for c in candidates:
        for name, text in runs[c.label].files.items():
            (tmp / name).write_text(text)
    with np.load(tmp / "trajectories.npz") as d:  # the plots read the records as written
        arrays = {k: d[k] for k in d.files}
    title = f"{scenario.name}: {label} ({what}) vs Drake"
    if report:  # last but compare.json: it lists the run's files
        write_report(tmp, figures, arrays, under=keys[primary.label], label=label, title=title,
                     layout=layout_of(scenario))
    else:
        artifacts.plot_divergence(tmp / "divergence.png", arrays, keys[primary.label], title, label=label)
    write_json(tmp / "compare.json", figures)


def _write_unjudged(out_dir, figures: dict, runs: dict, report: bool = False) -> None:
    """--no-truth's files: compare.json and every candidate's series (write_series' keys, per
    candidate slug) in trajectories.npz; with `report`, report.html and report.md (no plots:
    there is no truth to be off from)."""
    with atomic_directory(out_dir) as tmp:
        arrays = {}
        names = next((r.trajectory.names for r in runs.values() if len(r.trajectory.names)), ())
        arrays["names"] = np.array(names, dtype=str)  # the free containers, in the series' order (docs/commands.md)
        for label, run in runs.items():
            t, k = run.trajectory, slug(label)
            arrays.update({f"{k}_time": t.time, f"{k}_p_WB": t.p_WB, f"{k}_q_WB": t.q_WB, f"{k}_V_WB": t.V_WB,
                           f"{k}_energy": t.energy})
        np.savez_compressed(Path(tmp) / "trajectories.npz", **arrays)
        write_json(Path(tmp) / "compare.json", figures)
        if report:
            write_report(Path(tmp), figures)
    figures["out_dir"] = str(Path(out_dir))
