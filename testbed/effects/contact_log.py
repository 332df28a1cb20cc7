"""`contact_log`: per-step records of body states and ground-truth contacts.

With Drake's default sampled output ports, the contact results seen after step k
were computed from the state of step k-1; the logger pairs them with that state's
poses and signed distances, so every contact row is consistent with its poses.

Adds one system, `contact_logger`, that publishes every time step and records:
- `steps` table: step number, time, poses, spatial velocities and mechanical
  energy of every free container;
- `contacts` table: the driving model's answer for every contacting pair
  (testbed/contact/extraction.py lists the columns) plus both bodies' poses.

Other systems read the contacts as they are recorded through `latest_contacts()` and
`contacts_after(step)` (the learned_contact probe does), never the builder itself.
The static columns (p_W_cop_static, n_W of hydroelastic rows) are read from each
surface's faces every `static_every_steps` steps and held in between (`static_age` says
how old they are): see contact_extraction.StaticHold for why.
"""


import dataclasses

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.geometry import QueryObject
from pydrake.multibody.plant import ContactResults
from pydrake.systems.framework import LeafSystem

from testbed.contact import extraction as contact_extraction
from testbed.contact.body_index import geometry_body_index
from testbed.contact.surfaces import cross
from testbed.effects import register
from testbed.effects.base import Effect, Role
from testbed.geometry.boxes import QueryBoxes
from testbed.geometry.rotations import quaternion_from_rotation
from testbed.physics import GRAVITY  # [m/s^2], Drake's default MultibodyPlant gravity magnitude
from testbed.records import TableBuilder


@dataclasses.dataclass
class ContactLogConfig:
    # Record every `every_steps`-th step (1 = every step). Long resting runs can log
    # at, e.g., 10 ms without losing what they are judged on; each logged row still
    # pairs contacts with the poses of the state they were computed from.
    every_steps: int = 1
    # Read each hydroelastic surface's faces (pressure-weighted CoP and normal, the
    # static columns) every `static_every_steps` logged steps; held in between and marked
    # by `static_age`. 1 = every step (exact, ~0.15 ms per container-container surface).
    static_every_steps: int = 10


def _pose_columns(poses) -> tuple[np.ndarray, np.ndarray]:
    """poses: list of RigidTransform -> p (n, 3) [m], R (n, 3, 3) (one binding call per
    pose; the records' quaternions are computed once, in tables())."""
    M = np.array([X.GetAsMatrix34() for X in poses]).reshape(-1, 3, 4)
    return M[:, :, 3], M[:, :, :3]


class ContactLogger(LeafSystem):
    """Records steps and contacts at every plant time step (a periodic publish)."""

    def __init__(self, assembly, every_steps: int = 1, static_every_steps: int = 1):
        super().__init__()
        self.set_name("contact_logger")
        plant = assembly.plant
        self._plant_bodies = [assembly.bodies[n].index() for n in assembly.body_names]
        free_names = [c.name for c in assembly.scenario.containers if not c.fixed]
        self._free = [assembly.body_names.index(n) for n in free_names]
        self._free_body_index = [self._plant_bodies[i] for i in self._free]
        self._mass = np.array([assembly.bodies[n].default_mass() for n in free_names])  # (m,) [kg]
        self._com_B = np.array([assembly.bodies[n].default_com() for n in free_names])  # (m, 3) [m]
        self._I_Bcm_B = np.array([  # (m, 3, 3) [kg m^2] about the COM, in the body frame
            assembly.bodies[n].default_spatial_inertia().Shift(c).CalcRotationalInertia().CopyToFullMatrix3()
            for n, c in zip(free_names, self._com_B)
        ]).reshape(-1, 3, 3)
        self._owner = None
        self._boxes = None  # testbed.geometry.boxes.QueryBoxes of the scene, on the first record
        self._box_body = None  # each box's index into body_names (see _near)
        self._query_port = self.DeclareAbstractInputPort("query", AbstractValue.Make(QueryObject()))
        self._results_port = self.DeclareAbstractInputPort("contact_results", AbstractValue.Make(ContactResults()))
        self._poses_port = self.DeclareAbstractInputPort("body_poses", plant.get_body_poses_output_port().Allocate())
        self._velocities_port = self.DeclareAbstractInputPort(
            "body_spatial_velocities", plant.get_body_spatial_velocities_output_port().Allocate()
        )
        builder = assembly.builder
        builder.AddSystem(self)
        builder.Connect(assembly.scene_graph.get_query_output_port(), self._query_port)
        builder.Connect(plant.get_contact_results_output_port(), self._results_port)
        builder.Connect(plant.get_body_poses_output_port(), self._poses_port)
        builder.Connect(plant.get_body_spatial_velocities_output_port(), self._velocities_port)
        self._assembly = assembly
        self.steps: list[tuple] = []
        self.contacts = TableBuilder()
        self._sampled = plant.has_sampled_output_ports()
        self._every = every_steps
        self._hold = contact_extraction.StaticHold(static_every_steps * every_steps)  # in plant steps
        self._pending = None
        self._h = h = plant.time_step()
        period = every_steps * h
        self.DeclarePeriodicPublishEvent(period, 0.0, self._record)
        if self._sampled and every_steps > 1:
            # the state one step before each logged time: the contacts reported at the
            # logged time were computed from it
            self.DeclarePeriodicPublishEvent(period, period - h, self._snapshot)

    def _snapshot(self, context) -> None:
        """Steps row and pose/distance geometry of the current state, for the next record."""
        self._pending = self._geometry(context)

    def _geometry(self, context):
        query = self._query_port.Eval(context)
        if self._owner is None:
            self._owner = geometry_body_index(self._assembly, query)
        poses = self._poses_port.Eval(context)
        velocities = self._velocities_port.Eval(context)
        p, R_all = _pose_columns([poses[i] for i in self._plant_bodies])  # (nb, 3), (nb, 3, 3)
        V = np.array([velocities[i].get_coeffs() for i in self._free_body_index]).reshape(-1, 6)  # [w, v]
        step = int(round(context.get_time() / self._h))  # simulation step number
        free = self._free
        self.steps.append((step, context.get_time(), p[free], V, R_all[free]))  # q, energy: in tables()
        return (step, context.get_time(), p, R_all, self._near(query, p, R_all))

    def _near(self, query, p, R_all) -> dict:
        """contact_extraction.near_distances(query), from the bodies' poses just read: the
        scene's boxes and their poses in their bodies are read once (the lookup of
        near_distances' own cache and a GetPoseInWorld per box cost ~100 us a step)."""
        if self._boxes is None:

            self._boxes = QueryBoxes(query)
            inspector = query.inspector()
            if all(g in self._owner for g in self._boxes.ids):
                X_BG = np.array([inspector.GetPoseInFrame(g).GetAsMatrix34() for g in self._boxes.ids]).reshape(-1, 3, 4)
                self._box_body = np.array([self._owner[g] for g in self._boxes.ids], dtype=int)  # -> body_names
                self._p_BG, self._R_BG = X_BG[:, :, 3], X_BG[:, :, :3]
        if self._box_body is None:  # a box on no scene body: Drake's poses
            return self._boxes.near(query, contact_extraction.NEAR_DISTANCE)
        p_WB, R_WB = p[self._box_body], R_all[self._box_body]
        p_WG = p_WB + np.einsum("nij,nj->ni", R_WB, self._p_BG)
        return self._boxes.near_at(p_WG, R_WB @ self._R_BG, contact_extraction.NEAR_DISTANCE)

    def _record(self, context) -> None:
        if not self._sampled:  # unsampled ports: the results belong to this very state
            geometry = self._geometry(context)
        elif self._every > 1:  # the snapshot one step earlier holds the state they came from
            geometry, self._pending = self._pending, None
        else:
            # Sampled ports report the contacts of the last discrete update, computed
            # from the previous step's state: pair them with that state's geometry.
            geometry, self._pending = self._pending, self._geometry(context)
        if geometry is not None:
            self._append_contacts(context, geometry)

    def _append_contacts(self, context, geometry) -> None:
        step, t, p, R_all, distances = geometry
        columns = contact_extraction.from_contact_results(self._results_port.Eval(context), distances, self._owner,
                                                          hold=self._hold, step=step)
        # R_WA, R_WB (k, 3, 3) while running (what readers need); the table stores q_WA, q_WB
        columns["p_WA"], columns["R_WA"] = p[columns["a"]], R_all[columns["a"]]
        columns["p_WB"], columns["R_WB"] = p[columns["b"]], R_all[columns["b"]]
        self.contacts.append(step, t, columns)

    def latest_contacts(self) -> tuple[int, float, dict] | None:
        """(step, time, columns) of the most recent step with contacts, or None; columns
        as in contact_extraction plus p_WA, p_WB (k, 3) [m] and R_WA, R_WB (k, 3, 3) (the
        contacts table turns these into quaternions q_WA, q_WB)."""
        return self.contacts.latest()

    def contacts_after(self, step: int) -> list[tuple[int, float, dict]]:
        """[(step, time, columns)] of the recorded steps after `step`, oldest first."""
        return [(int(c["step"][0]), float(c["time"][0]), c) for c in self.contacts.chunks_after_step(step)]

    def _energy(self, p_WBo, R_WB, V_WB):
        """Kinetic and potential energy [J] of the free containers, summed over bodies, for
        T logged steps at once: p_WBo (T, m, 3) [m], R_WB (T, m, 3, 3), V_WB (T, m, 6)
        [rad/s, m/s] (w, v of the body origin, in W). Returns two (T,) arrays."""
        w, v_Bo = V_WB[..., :3], V_WB[..., 3:]
        p_BoBcm_W = np.einsum("tnij,nj->tni", R_WB, self._com_B)
        v_cm = v_Bo + cross(w, p_BoBcm_W)
        I_W = R_WB @ self._I_Bcm_B @ np.swapaxes(R_WB, -1, -2)  # (T, m, 3, 3)
        Iw = np.einsum("tnij,tnj->tni", I_W, w)
        kinetic = 0.5 * np.einsum("n,tni,tni->t", self._mass, v_cm, v_cm) + 0.5 * np.einsum("tni,tni->t", w, Iw)
        potential = GRAVITY * np.einsum("n,tn->t", self._mass, p_WBo[..., 2] + p_BoBcm_W[..., 2])
        return kinetic, potential

    def tables(self) -> dict[str, dict]:
        m = len(self._free)
        if self.steps:
            k, t, p, V, R = (np.asarray(x) for x in zip(*self.steps))
            V, R = V.reshape(len(k), m, 6), R.reshape(len(k), m, 3, 3)
            q = quaternion_from_rotation(R)
            ke, pe = self._energy(p.reshape(len(k), m, 3), R, V)
        else:
            k, t, p, q, V, ke, pe = (np.zeros(0, dtype=np.int64), np.zeros(0), np.zeros((0, m, 3)), np.zeros((0, m, 4)),
                                     np.zeros((0, m, 6)), np.zeros(0), np.zeros(0))
        steps = {"step": k, "time": t, "p_WB": p, "q_WB": q, "V_WB": V, "kinetic_energy": ke, "potential_energy": pe}
        empty = contact_extraction.empty_columns()
        empty.update(p_WA=np.zeros((0, 3)), R_WA=np.zeros((0, 3, 3)), p_WB=np.zeros((0, 3)), R_WB=np.zeros((0, 3, 3)))
        contacts = self.contacts.build(empty)
        contacts["q_WA"] = quaternion_from_rotation(contacts.pop("R_WA")).reshape(-1, 4)
        contacts["q_WB"] = quaternion_from_rotation(contacts.pop("R_WB")).reshape(-1, 4)
        return {"steps": steps, "contacts": contacts}


@register
class ContactLogEffect(Effect):
    name = "contact_log"
    Config = ContactLogConfig
    role = Role.RECORDER
    order = 10

    def check(self, effects) -> None:
        super().check(effects)
        if not (isinstance(self.config.every_steps, int) and self.config.every_steps >= 1):
            raise self.fail("every_steps", f"expected a whole number of steps >= 1, got {self.config.every_steps}")
        if not (isinstance(self.config.static_every_steps, int) and self.config.static_every_steps >= 1):
            raise self.fail("static_every_steps",
                            f"expected a whole number of logged steps >= 1, got {self.config.static_every_steps}")

    def add_systems(self, assembly) -> list:
        self.logger = ContactLogger(assembly, self.config.every_steps, self.config.static_every_steps)
        return [self.logger]

    def collect(self, tables: dict[str, dict]) -> None:
        tables.update(self.logger.tables())

    def summarize(self, tables: dict[str, dict]) -> dict:
        contacts, steps = tables["contacts"], tables["steps"]
        energy = steps["kinetic_energy"] + steps["potential_energy"]
        return {
            "logged_steps": int(len(steps["time"])),
            "contact_rows": int(len(contacts["a"])),
            "max_contacts_per_step": int(np.bincount(contacts["step"]).max()) if len(contacts["step"]) else 0,
            "max_penetration_m": float(max(0.0, -np.nanmin(contacts["phi"]))) if len(contacts["phi"]) else 0.0,
            "energy_drift_J": float(energy[-1] - energy[0]) if len(energy) else 0.0,
        }
