"""Writing an effect: a sideways gust on every free container, switched on by a scene's
`effects: {gust: {...}}`. A shipped effect is one module in testbed/effects/ (the registry
imports them all); a script may register its own before it loads a scene, as here.
Run: python examples/write_an_effect.py (about 10 s)."""

import dataclasses

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.multibody.math import SpatialForce
from pydrake.multibody.plant import ExternallyAppliedSpatialForce
from pydrake.systems.framework import LeafSystem

from testbed.effects import Effect, Role, register


@dataclasses.dataclass
class GustConfig:  # the YAML schema of effects.gust
    force: float = 50_000.0  # [N] along world +y, on every free container
    start: float = 0.1  # [s]
    length: float = 0.2  # [s]


class GustLoad(LeafSystem):
    """Outputs the gust's spatial forces (world frame, applied at each container's centre)."""

    def __init__(self, assembly, config: GustConfig):
        super().__init__()
        self._cfg = config
        self._bodies = [assembly.bodies[c.name] for c in assembly.scenario.containers if not c.fixed]
        self.DeclareAbstractOutputPort("spatial_forces", lambda: AbstractValue.Make([ExternallyAppliedSpatialForce()]),
                                       self._calc)
        assembly.builder.AddSystem(self)
        assembly.add_spatial_forces(self.get_output_port())

    def _calc(self, context, output):
        on = self._cfg.start <= context.get_time() < self._cfg.start + self._cfg.length
        forces = []
        for body in self._bodies:
            f = ExternallyAppliedSpatialForce()
            f.body_index, f.p_BoBq_B = body.index(), np.zeros(3)
            f.F_Bq_W = SpatialForce(tau=np.zeros(3), f=np.array([0.0, self._cfg.force if on else 0.0, 0.0]))
            forces.append(f)
        output.set_value(forces)


@register
class GustEffect(Effect):
    name = "gust"
    Config = GustConfig
    role = Role.PHYSICS  # it changes the dynamics (a recorder or viewer would say so instead)

    def check(self, effects):
        super().check(effects)
        if not self.config.force >= 0:
            raise self.fail("force", f"expected a non-negative force [N], got {self.config.force}")

    def add_systems(self, assembly):
        return [GustLoad(assembly, self.config)]


if __name__ == "__main__":
    from testbed import load_scenario, run_scenario  # after the registration: the scene schema includes gust

    scenario = load_scenario("single_drop", overrides=["effects.gust={force: 200000}", "duration=0.5"])
    steps = run_scenario(scenario).tables["steps"]
    print(f"single_drop with a 200 kN gust: the box moved {steps['p_WB'][-1, 0, 1] * 1e3:.1f} mm along +y")
    try:
        load_scenario("single_drop", overrides=["effects.gust={force: -1}"])
    except Exception as error:  # a bad value is one line naming the field
        print(f"refused: {error}")
