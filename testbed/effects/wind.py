"""`wind`: a steady horizontal wind load on every free container.

Pressure q = 0.5 * rho_air * v^2 * Cd [Pa] acts on each container's area projected
on the plane normal to the wind (its exposed side area; no sheltering by neighbours:
a conservative choice for stacks, whose sides are all exposed). The force is
horizontal, along the wind, applied at the container's geometric centre (the centre
of its side area), and ramps up linearly over `ramp_time` so a scene does not start
with an impulse. Adds one system, `wind_load`.
"""


import dataclasses
import math

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.multibody.math import SpatialForce
from pydrake.multibody.plant import ExternallyAppliedSpatialForce
from pydrake.systems.framework import LeafSystem

from testbed.effects import register
from testbed.effects.base import Effect, Role


@dataclasses.dataclass
class WindConfig:
    speed: float = 20.0  # [m/s] mean wind speed (20 m/s: crane operations usually stop near here)
    direction_deg: float = 90.0  # direction the wind blows TOWARDS, from world +x about +z [deg]
    air_density: float = 1.225  # [kg/m^3] sea-level standard atmosphere
    drag_coefficient: float = 1.2  # [-] a sharp-edged box broadside (handbook range 1.05-1.3)
    ramp_time: float = 0.5  # [s] linear ramp from 0 to full load


def projected_area(size, R_WC, direction_W) -> float:
    """Area [m^2] of a box of full extents `size` (3,) with orientation R_WC (3, 3),
    projected on the plane normal to the unit vector `direction_W` (3,)."""
    lx, ly, lz = size
    face_areas = np.array([ly * lz, lx * lz, lx * ly])  # faces normal to x, y, z of C
    return float(np.sum(face_areas * np.abs(R_WC.T @ direction_W)))


class WindLoad(LeafSystem):
    def __init__(self, assembly, config: WindConfig):
        super().__init__()
        self.set_name("wind_load")
        plant = assembly.plant
        specs = [c for c in assembly.scenario.containers if not c.fixed]
        self._bodies = [assembly.bodies[c.name] for c in specs]
        self._sizes = [c.container_type().size for c in specs]
        angle = math.radians(config.direction_deg)
        self._direction_W = np.array([math.cos(angle), math.sin(angle), 0.0])
        self._pressure = 0.5 * config.air_density * config.speed**2 * config.drag_coefficient  # [Pa]
        self._ramp = config.ramp_time
        self._poses = self.DeclareAbstractInputPort("body_poses", plant.get_body_poses_output_port().Allocate())
        self.DeclareAbstractOutputPort(
            "spatial_forces", lambda: AbstractValue.Make([ExternallyAppliedSpatialForce()]), self._calc
        )
        assembly.builder.AddSystem(self)
        assembly.builder.Connect(plant.get_body_poses_output_port(), self._poses)
        assembly.add_spatial_forces(self.get_output_port())

    def _calc(self, context, output) -> None:
        t = context.get_time()
        scale = 1.0 if self._ramp <= 0 else min(1.0, t / self._ramp)
        poses = self._poses.Eval(context)
        forces = []
        for body, size in zip(self._bodies, self._sizes):
            R_WC = poses[int(body.index())].rotation().matrix()
            f = ExternallyAppliedSpatialForce()
            f.body_index = body.index()
            f.p_BoBq_B = np.zeros(3)  # geometric centre = body origin
            magnitude = scale * self._pressure * projected_area(size, R_WC, self._direction_W)
            f.F_Bq_W = SpatialForce(tau=np.zeros(3), f=magnitude * self._direction_W)
            forces.append(f)
        output.set_value(forces)


@register
class WindEffect(Effect):
    name = "wind"
    Config = WindConfig
    role = Role.PHYSICS
    translated_by = ("mujoco",)
    order = 20

    def check(self, effects) -> None:
        super().check(effects)
        for field in ("speed", "air_density", "drag_coefficient", "ramp_time"):
            value = getattr(self.config, field)
            if not (math.isfinite(value) and value >= 0):
                raise self.fail(field, f"expected a finite non-negative number, got {value}")

    def add_systems(self, assembly) -> list:
        return [WindLoad(assembly, self.config)]

    def summarize(self, tables) -> dict:
        c = self.config
        return {"wind_pressure_Pa": 0.5 * c.air_density * c.speed**2 * c.drag_coefficient}
