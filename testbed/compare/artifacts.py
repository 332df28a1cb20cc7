"""Files of a twin run: time series (.npz), divergence plot (PNG, drawn by report_plots.py), ghost replay (HTML)."""

from __future__ import annotations

import numpy as np

from testbed.compare.external_work import external_work, power_laws
from testbed.compare.report_plots import divergence_figure
from testbed.document import png
from testbed.viz.camera import set_camera_on
from testbed.viz.replay import finish_recording, with_caption
from testbed.viz.server import start_meshcat


def write_series(path, runs: dict, under_test: str = "learned", scenario=None) -> None:
    """trajectories.npz: per run kind K ('truth', 'learned' or 'mujoco', 'point'): K_time (n,) [s],
    K_p_WB (n, m, 3) [m], K_q_WB (n, m, 4) (w, x, y, z), K_V_WB (n, m, 6), K_energy (n,) [J];
    names (m,) the free containers; position_error (n, m) [m] the run `under_test` vs truth.
    With the `scenario` that ran, where its external actors' power is a function of the records
    (testbed/compare/external_work.py): K_external_work (n,) [J] the work W(t) the wind, a crane
    or the moving deck did on K's containers since t = 0 (zeros without such an actor) and
    external_actors (the effects counted)."""
    arrays = {"names": np.array(runs["truth"].names)}
    laws = None if scenario is None else power_laws(scenario)
    for kind, t in runs.items():
        arrays.update({f"{kind}_time": t.time, f"{kind}_p_WB": t.p_WB, f"{kind}_q_WB": t.q_WB,
                       f"{kind}_V_WB": t.V_WB, f"{kind}_energy": t.energy})
        work = None if laws is None else external_work(laws, t)  # None: an actor's stop time unknown
        if work is not None:
            arrays[f"{kind}_external_work"] = work
    if laws is not None:
        arrays["external_actors"] = np.array([name for name, _ in laws], dtype=str)
    n = len(runs[under_test].time)
    arrays["position_error"] = np.linalg.norm(runs[under_test].p_WB - runs["truth"].p_WB[:n], axis=2)
    np.savez_compressed(path, **arrays)


def plot_divergence(path, series, under: str, title: str, label: str = "learned") -> None:
    """divergence.png: the run under test's position error over time (its worst containers, the
    median and the max over all) and the energy raw and net of the external actors' work, of it
    and of Drake's (report_plots.divergence_figure); series: trajectories.npz's arrays, under: the
    run under test's prefix there, label: its name in the legends ('learned', 'MuJoCo')."""
    with open(path, "wb") as f:
        f.write(png(divergence_figure(series, under, title, label=label), dpi=90))


def write_ghost_replay(path, scenario, truth, learned, frame_period: float = 0.02, label: str = "learned") -> None:
    """A self-contained Meshcat replay: the run under test's boxes solid (under /<label>/ in
    the scene tree), the truth as translucent ghosts; the camera on the containers from a 3/4
    view, a caption with the scene, which box is which and the simulated time. The Meshcat
    server only records (its URL is not printed: it is gone when the command exits)."""
    from pydrake.common.eigen_geometry import Quaternion
    from pydrake.geometry import Box, Rgba
    from pydrake.math import RigidTransform

    meshcat = start_meshcat(port=0, quiet=True)
    specs = [c for c in scenario.containers if not c.fixed]
    fixed = [c for c in scenario.containers if c.fixed]
    for c in specs + fixed:
        size = c.container_type().size
        r, g, b, _ = c.container_type().rgba
        meshcat.SetObject(f"/{label}/{c.name}", Box(*size), Rgba(r, g, b, 1.0))
        if not c.fixed:
            meshcat.SetObject(f"/truth_ghost/{c.name}", Box(*size), Rgba(0.6, 0.9, 1.0, 0.35))
        else:
            meshcat.SetTransform(f"/{label}/{c.name}", c.pose())
    if scenario.ground:
        meshcat.SetObject("/quay", Box(60.0, 60.0, 0.2), Rgba(0.5, 0.5, 0.5, 1.0))
        meshcat.SetTransform("/quay", RigidTransform([0.0, 0.0, -0.1]))
    set_camera_on(meshcat, scenario.containers)
    meshcat.StartRecording(frames_per_second=1.0 / frame_period, set_visualizations_while_recording=False)
    step = max(1, int(round(frame_period / max(truth.time[1] - truth.time[0], 1e-9)))) if len(truth.time) > 1 else 1
    for k in range(0, len(truth.time), step):
        t = float(truth.time[k])
        for i, c in enumerate(specs):
            meshcat.SetTransform(f"/truth_ghost/{c.name}", _pose(Quaternion, RigidTransform, truth, k, i), t)
            if k < len(learned.time):
                meshcat.SetTransform(f"/{label}/{c.name}", _pose(Quaternion, RigidTransform, learned, k, i), t)
    html = with_caption(finish_recording(meshcat), f"{scenario.name}: the {label} run against Drake", (
        f"solid boxes (container colours): the {label} run",
        "light blue, translucent: Drake's run from the same initial state (the truth)"))
    with open(path, "w") as f:
        f.write(html)


def _pose(Quaternion, RigidTransform, traj, k, i):
    q = traj.q_WB[k, i]
    return RigidTransform(Quaternion(q / np.linalg.norm(q)), traj.p_WB[k, i])
