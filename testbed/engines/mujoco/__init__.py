"""MuJoCo behind the Engine protocol (testbed/engines/base.py).

  model.py   Scenario -> MJCF -> MjModel, with MuJoCo's default contact parameters or a
             set matched to Drake's hydroelastic contact (the derivation is its docstring)
  run.py     simulate_mujoco: steps a translated scene, records the Drake-shaped `steps`
             and per-pair `contacts` tables and the wall time; trajectory_of
  crane.py   the crane effect's ropes and twistlocks as MuJoCo applied forces

The registration stays light (the CLI's parser lists the engines): the modules above load
when a scene is checked or run, and the `mujoco` package only when one is translated; a
missing one is an OptionalDependencyError with the install command.
"""

from __future__ import annotations

from testbed.engines import register
from testbed.engines.base import Engine, EngineRun
from testbed.errors import OptionalDependencyError

PARAM_SETS = ("matched", "default")  # MuJoCo's contact-parameter sets, the default first (model.py)


@register
class MujocoEngine(Engine):
    """MuJoCo; params: 'matched' (to Drake's hydroelastic contact, the default) or 'default';
    no predictor."""

    name = "mujoco"
    label = "MuJoCo"
    order = 20
    param_sets = PARAM_SETS
    query_method = "mujoco"
    report_note = ("MuJoCo: a whole-simulator alternative, with contact parameters 'matched' to Drake's hydroelastic "
                   "stiffness and its discrete step's dissipation and with MuJoCo's 'default' ones, against Drake's run of "
                   "the scene's own contact model; its contacts per body pair are reduced to the force-weighted centroid "
                   "and compared with Drake's centre of pressure in the contact plane.")

    def unavailable(self) -> str | None:
        from testbed.engines.mujoco.model import mujoco_module

        try:
            mujoco_module()
        except (ImportError, OptionalDependencyError) as e:
            return str(e).strip().splitlines()[0]
        return None

    def version(self) -> str:
        from testbed.engines.mujoco.model import mujoco_module

        return mujoco_module().__version__

    def check(self, scenario) -> None:
        from testbed.engines.mujoco.model import check_supported

        check_supported(scenario)

    def run(self, scenario, *, duration=None, record_every=1, params=None, predictor=None, contacts=False,
            source="<scenario>"):
        from testbed.engines.mujoco.run import simulate_mujoco, trajectory_of

        self.refuse_unused(params, predictor)
        run = simulate_mujoco(scenario, duration=duration, params=params or self.param_sets[0])
        summary = {**run.summary, "version": run.summary["mujoco_version"]}
        return EngineRun(trajectory_of(run, record_every), run.tables["contacts"] if contacts else None, summary,
                         {"mujoco.xml": run.mjcf})
