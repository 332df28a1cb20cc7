"""Open-loop Drake rollouts of recorded cube tosses, and the per-toss error metric.

`TossSimulator` builds one plant (cube on a flat table) for one parameter set and reuses
it for every toss it is given: a build costs far more than the state reset between tosses.
Metric (Acosta, Yang and Posa, RA-L 2022): per toss, the mean over frames of
|p_data - p_sim| / CUBE_WIDTH; the rotation error is the mean angle of R_data^T R_sim [deg].
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from pydrake.math import RigidTransform
from pydrake.multibody.math import SpatialVelocity
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from testbed.bodies import models as model_loading
from testbed.calibration.data import CUBE_INERTIA, CUBE_MASS, CUBE_WIDTH, TABLE_HEIGHT, Toss
from testbed.calibration.initial_state import first_frame, initial_state
from testbed.drake_support import missing_approximation
from testbed.errors import SimulationError, TestbedError
from testbed.geometry.rotations import angle_between_quaternions_deg
from testbed.simulation import advance

MODELS = ("point", "hydroelastic")
# Drake's contact_surface_representation: "polygon" (the default: each polygon's force at its
# centroid) or "triangle" (each polygon split into triangles around its centroid, one point each:
# half the one-point rule's moment error). The truth ladder's rungs for the tosses.
REPRESENTATIONS = ("polygon", "triangle")
APPROXIMATIONS = ("sap", "similar", "lagged", "tamsi")  # 'tamsi' only up to Drake 1.56 (testbed.drake_support)
FAILED_TOSS_ERROR = 1.0  # [cube widths] charged for a rollout whose solver failed (worse than any real fit)


@dataclasses.dataclass
class CubeTossParams:
    """Contact parameters of a cube-toss rollout. Every per-geometry value is set on the cube
    AND on the table, so Drake's combination rules give the pair: friction 2ab/(a+b) = mu,
    point stiffness in series = point_contact_stiffness / 2, relaxation time and
    Hunt-Crossley dissipation as documented for Drake's combination (same value on both).
    Hydroelastic: the cube is compliant (modulus below), the table rigid."""

    model: str = "point"  # one of MODELS (Drake's contact_model)
    approximation: str = "sap"  # Drake's discrete_contact_approximation
    time_step: float = 1.0e-3  # [s] requested; rounded down so that frames fall on steps
    mu: float = 0.3  # mu_dynamic = mu_static on both geometries
    point_contact_stiffness: float = 2.0e4  # [N/m] per geometry
    hydroelastic_modulus: float = 1.0e6  # [Pa] of the cube
    relaxation_time: float = 1.0e-3  # [s] per geometry (SAP's dissipation)
    hunt_crossley_dissipation: float = 5.0  # [s/m] per geometry (TAMSI, similar, lagged)
    hydroelastic_margin: float = 0.0  # [m] of the cube
    table_height: float = TABLE_HEIGHT  # [m] z of the table top
    # [m] point contact only: > 0 replaces the box's collision geometry by 8 spheres of this
    # radius inside its corners (a cube with rounded corners); 0 = the box
    corner_spheres: float = 0.0
    # [m/s] MultibodyPlantConfig.stiction_tolerance: the slip speed below which TAMSI's
    # regularised friction counts as sticking (ignored by SAP, similar, lagged)
    stiction_tolerance: float = 1.0e-4
    # hydroelastic only: Drake's contact_surface_representation, one of REPRESENTATIONS
    contact_surface_representation: str = "polygon"

    def check(self) -> None:
        if self.model not in MODELS:
            raise TestbedError(f"model: unknown {self.model!r}; expected one of: {', '.join(MODELS)}")
        if self.approximation not in APPROXIMATIONS:
            raise TestbedError(f"approximation: unknown {self.approximation!r}; expected one of: {', '.join(APPROXIMATIONS)}")
        if self.contact_surface_representation not in REPRESENTATIONS:
            raise TestbedError(f"contact_surface_representation: unknown {self.contact_surface_representation!r}; "
                               f"expected one of: {', '.join(REPRESENTATIONS)}")
        missing = missing_approximation(self.approximation)
        if missing:
            raise TestbedError(f"approximation: {missing}")
        for name in ("time_step", "mu", "point_contact_stiffness", "hydroelastic_modulus", "stiction_tolerance"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise TestbedError(f"{name}: expected a positive number, got {value}")
        for name in ("relaxation_time", "hunt_crossley_dissipation", "hydroelastic_margin", "corner_spheres"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise TestbedError(f"{name}: expected a non-negative number, got {value}")

    def proximity(self) -> dict[str, float]:
        """drake:proximity_properties values, the same on cube and table."""
        return {
            "mu_dynamic": self.mu, "mu_static": self.mu,
            "point_contact_stiffness": self.point_contact_stiffness,
            "hydroelastic_modulus": self.hydroelastic_modulus,
            "hydroelastic_margin": self.hydroelastic_margin,
            "relaxation_time": self.relaxation_time,
            "hunt_crossley_dissipation": self.hunt_crossley_dissipation,
        }


@dataclasses.dataclass(frozen=True)
class TossResult:
    toss_id: int
    position_error: float  # mean over frames of |p_data - p_sim| / CUBE_WIDTH
    rotation_error_deg: float  # mean over frames of angle(R_data^T R_sim) [deg]
    failed: bool  # the rollout failed (testbed.simulation's convention); errors are FAILED_TOSS_ERROR / NaN


def initial_velocity(toss: Toss) -> tuple[np.ndarray, np.ndarray]:
    """(w_WB_W, v_WB_W) at the first frame, both (3,) in W: the stored angular velocity is
    expressed in the body frame B and is rotated by R_WB; Drake takes it in W."""
    _, _, w_W, v_W = first_frame(toss)
    return w_W, v_W


class TossSimulator:
    """One diagram (cube + table) for one parameter set; `rollout` reuses it for any toss."""

    def __init__(self, params: CubeTossParams, frame_dt: float):
        params.check()
        self.params = params
        substeps = max(1, math.ceil(frame_dt / params.time_step - 1e-9))
        self.time_step = frame_dt / substeps  # frames land on steps
        builder = DiagramBuilder()
        config = MultibodyPlantConfig(time_step=self.time_step, contact_model=params.model,
                                      discrete_contact_approximation=params.approximation,
                                      stiction_tolerance=params.stiction_tolerance,
                                      contact_surface_representation=params.contact_surface_representation)
        plant, _ = AddMultibodyPlant(config, builder)
        parser = Parser(plant)
        parser.SetStrictParsing()
        props = params.proximity()
        cube_text = model_loading.box_sdf(
            name="cube", size=[CUBE_WIDTH] * 3, mass=CUBE_MASS, inertia=[CUBE_INERTIA] * 3,
            properties=props, corner_spheres=params.corner_spheres if params.model == "point" else 0.0,
            box_collision=params.model != "point" or params.corner_spheres == 0.0)
        (cube,) = parser.AddModelsFromString(cube_text, "sdf")
        parser.AddModelsFromString(model_loading.flat_ground_sdf(shape="slab", height=params.table_height, size=(20.0, 20.0, 1.0), properties=props), "sdf")
        plant.Finalize()
        self.plant, self.body = plant, plant.GetBodyByName("body", cube)
        self.diagram = builder.Build()
        self.simulator = Simulator(self.diagram)
        self.context = self.simulator.get_mutable_context()
        self.plant_context = plant.GetMyMutableContextFromRoot(self.context)

    def rollout(self, toss: Toss, initial: str = "first-frame") -> tuple[np.ndarray, np.ndarray]:
        """(p_WB (n, 3) [m], q_WB (n, 4) w,x,y,z) simulated at the toss's frame times from the
        state at t = 0 that `initial` names (initial_state.INITIAL_STATES; the published
        protocol is "first-frame"), through the one sampled-run loop (testbed.simulation.advance).
        Raises SimulationError (a RuntimeError) when the run fails (the solver, a non-finite state)."""
        self.context.SetTime(0.0)
        R_WB, p_WB, w, v = initial_state(toss, initial, self.params.table_height)
        self.plant.SetFreeBodyPose(self.plant_context, self.body, RigidTransform(R_WB, p_WB))
        self.plant.SetFreeBodySpatialVelocity(self.plant_context, self.body, SpatialVelocity(w=w, v=v))
        self.simulator.Initialize()
        p = np.empty((len(toss), 3))
        q = np.empty((len(toss), 4))
        frames = iter(range(len(toss)))

        def record(_t=None):
            k = next(frames)
            X = self.plant.EvalBodyPoseInWorld(self.plant_context, self.body)
            p[k] = X.translation()
            q[k] = X.rotation().ToQuaternion().wxyz()

        record()
        _, failure = advance(self.simulator, [float(t) for t in toss.t[1:]], record,
                             positions=lambda: self.plant.GetPositions(self.plant_context))
        if failure is not None:
            raise SimulationError(f"toss {toss.toss_id}: the rollout failed at t = {failure.time:.4f} s: "
                                  f"{failure.describe()}")
        return p, q

    def evaluate(self, toss: Toss, initial: str = "first-frame") -> TossResult:
        try:
            p, q = self.rollout(toss, initial)
        except RuntimeError:
            return TossResult(toss.toss_id, FAILED_TOSS_ERROR, float("nan"), True)
        position = float(np.mean(np.linalg.norm(p - toss.p_WB, axis=1)) / CUBE_WIDTH)
        rotation = float(np.mean(angle_between_quaternions_deg(q, toss.q_WB)))
        return TossResult(toss.toss_id, position, rotation, False)
