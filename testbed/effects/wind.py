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
    return float(_projected_areas(_face_areas(size), np.asarray(R_WC, float)[None], direction_W)[0])


def _face_areas(sizes) -> np.ndarray:
    """(k, 3) [m^2] the areas of the faces normal to x, y, z of boxes of full extents sizes (k, 3)."""
    sizes = np.asarray(sizes, float).reshape(-1, 3)
    return np.column_stack([sizes[:, 1] * sizes[:, 2], sizes[:, 0] * sizes[:, 2], sizes[:, 0] * sizes[:, 1]])


def _projected_areas(faces, R_WC, direction_W) -> np.ndarray:
    """(k,) [m^2] boxes of face areas faces (k, 3), orientations R_WC (k, 3, 3), projected on
    the plane normal to direction_W (3,): sum_i face_i |R_WC[:, i] . d|."""
    return np.einsum("ki,ki->k", faces, np.abs(np.einsum("kji,j->ki", R_WC, np.asarray(direction_W, float))))


class WindLaw:
    """The wind load on k containers at once, the one statement of the law (the module
    docstring): Drake's WindLoad and both MuJoCo engines call it. sizes (k, 3) [m] full extents."""

    def __init__(self, config: "WindConfig", sizes):
        angle = math.radians(config.direction_deg)
        self.direction = np.array([math.cos(angle), math.sin(angle), 0.0])  # unit, in W
        self.pressure = 0.5 * config.air_density * config.speed**2 * config.drag_coefficient  # [Pa]
        self.ramp = config.ramp_time  # [s]
        self.faces = _face_areas(sizes)

    def forces_W(self, R_WC, t: float) -> np.ndarray:
        """(k, 3) [N] the force on each container (orientations R_WC (k, 3, 3)) at time t [s],
        applied at its geometric centre: pressure x projected area, along the wind, ramped."""
        scale = 1.0 if self.ramp <= 0 else min(1.0, t / self.ramp)
        area = _projected_areas(self.faces, R_WC, self.direction)  # [m^2]
        return (scale * self.pressure * area)[:, None] * self.direction

    def mujoco_rows(self, R_WC, com_B, t: float) -> np.ndarray:
        """(k, 6) rows of MuJoCo's xfrc_applied [force, torque about the COM, in W]: the force
        at the geometric centre C, whose COM is com_B (k, 3) [m] from C in C."""
        f = self.forces_W(R_WC, t)
        return np.hstack([f, np.cross(-np.einsum("kij,kj->ki", R_WC, com_B), f)])

    def power_W(self, t: float, R_WC, v_WC) -> float:
        """[W] the wind's power on the k containers at time t [s]: sum of forces_W . v_WC, with
        v_WC (k, 3) [m/s] the velocities of their geometric centres (where the force acts), in W."""
        return float(np.einsum("ki,ki->", self.forces_W(np.asarray(R_WC, float).reshape(-1, 3, 3), t),
                               np.asarray(v_WC, float).reshape(-1, 3)))


class WindLoad(LeafSystem):
    def __init__(self, assembly, config: WindConfig):
        super().__init__()
        self.set_name("wind_load")
        plant = assembly.plant
        specs = [c for c in assembly.scenario.containers if not c.fixed]
        self._bodies = [assembly.bodies[c.name] for c in specs]
        self._sizes = [c.container_type().size for c in specs]
        self._law = WindLaw(config, np.array(self._sizes, dtype=float).reshape(-1, 3))
        self._poses = self.DeclareAbstractInputPort("body_poses", plant.get_body_poses_output_port().Allocate())
        self.DeclareAbstractOutputPort(
            "spatial_forces", lambda: AbstractValue.Make([ExternallyAppliedSpatialForce()]), self._calc
        )
        assembly.builder.AddSystem(self)
        assembly.builder.Connect(plant.get_body_poses_output_port(), self._poses)
        assembly.add_spatial_forces(self.get_output_port())

    def _calc(self, context, output) -> None:
        poses = self._poses.Eval(context)
        R_WC = np.array([poses[int(body.index())].rotation().matrix() for body in self._bodies]).reshape(-1, 3, 3)
        forces = []
        for body, f_W in zip(self._bodies, self._law.forces_W(R_WC, context.get_time())):
            f = ExternallyAppliedSpatialForce()
            f.body_index = body.index()
            f.p_BoBq_B = np.zeros(3)  # geometric centre = body origin
            f.F_Bq_W = SpatialForce(tau=np.zeros(3), f=f_W)
            forces.append(f)
        output.set_value(forces)


@register
class WindEffect(Effect):
    name = "wind"
    Config = WindConfig
    role = Role.PHYSICS
    translated_by = ("mujoco", "bullet")
    order = 20

    def check(self, effects) -> None:
        super().check(effects)
        for field in ("speed", "air_density", "drag_coefficient", "ramp_time"):
            value = getattr(self.config, field)
            if not (math.isfinite(value) and value >= 0):
                raise self.fail(field, f"expected a finite non-negative number, got {value}")

    def add_systems(self, assembly) -> list:
        return [WindLoad(assembly, self.config)]

    def external_power(self):
        """The wind's power [W] on the scene's free containers (scene order) as a function of a
        record: (t [s], p_WB (m, 3) [m], R_WB (m, 3, 3), v_WB (m, 3) [m/s] body-origin velocities,
        w_WB (m, 3) [rad/s]) -> W, all in W (testbed/compare/external_work.py integrates it)."""
        specs = [c for c in self.scenario.containers if not c.fixed]
        law = WindLaw(self.config, np.array([c.container_type().size for c in specs], float).reshape(-1, 3))
        return lambda t, p, R, v, w: law.power_W(t, R, v)

    def summarize(self, tables) -> dict:
        c = self.config
        return {"wind_pressure_Pa": 0.5 * c.air_density * c.speed**2 * c.drag_coefficient}
