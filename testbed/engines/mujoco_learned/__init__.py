"""MuJoCo hosting the learned contact: `mujoco_learned` behind the Engine protocol.

MuJoCo integrates the containers' rigid-body motion; a learned predictor decides every
container-container contact with the force law of the Drake-hosted loop
(testbed/effects/learned_dynamics: the same contact step), applied through xfrc_applied each step;
MuJoCo's own (matched) contact handles the quay. loop.py holds the run and says why.

predictor: any learned_contact.sources spec (improved, paper, a .npz or .onnx file,
module:attribute; None: the scene's learned_dynamics predictor if it declares one, else
"improved"). No contact-parameter sets: the quay's contact is MuJoCo's `matched` set, fixed.
The registration stays light: loop.py, MuJoCo and the native step load when a scene runs.
"""

from __future__ import annotations

from learned_contact import sources
from testbed.engines import register
from testbed.engines.base import Engine, EngineRun

DEFAULT_PREDICTOR = sources.DEFAULT


@register
class MujocoLearnedEngine(Engine):
    """MuJoCo's rigid-body step with the learned container contact; predictor: its spec."""

    name = "mujoco_learned"
    label = "MuJoCo + learned"
    order = 30
    learned = True  # a predictor decides its contact: judged at the learned law's modulus, by the closed-loop gates
    report_note = ("MuJoCo + learned: MuJoCo steps the bodies and the shipped predictor decides container-container "
                   "contact with the learned loop's force law (testbed/engines/mujoco_learned), judged against Drake at "
                   "the learned law's modulus.")

    def unavailable(self) -> str | None:
        from testbed.engines.mujoco import MujocoEngine

        return MujocoEngine().unavailable()

    def version(self) -> str:
        from testbed.engines.mujoco.model import mujoco_module

        return mujoco_module().__version__

    def check(self, scenario) -> None:
        from testbed.engines.mujoco_learned.loop import prepare

        prepare(scenario, None)

    def run(self, scenario, *, duration=None, record_every=1, params=None, predictor=None, contacts=False,
            source="<scenario>"):
        from testbed.engines.mujoco_learned.loop import UnstableStepError, refused_run, simulate

        self.refuse_unused(params, None)
        try:
            run = simulate(scenario, duration=duration, predictor=predictor, record_every=record_every, source=source)
        except UnstableStepError as e:  # a step the explicit law cannot take (a sweep's): the run fails at once
            return EngineRun(refused_run(scenario, str(e)), _no_rows() if contacts else None,
                             {"engine": self.name, "wall_per_sim_s": float("nan"), "diverged": True})
        return EngineRun(run.trajectory, run.contacts if contacts else None, run.summary, {"mujoco_learned.xml": run.mjcf})


def _no_rows() -> dict:
    """Contact rows of no contact (the Engine protocol's shape)."""
    import numpy as np

    rows = {k: np.zeros((0, 3)) for k in ("p_W_cop", "n_W", "f_W")}
    rows.update({k: np.zeros(0) for k in ("time", "fn", "phi")})
    rows.update({k: np.zeros(0, dtype=int) for k in ("step", "a", "b", "n_points")})
    return rows
