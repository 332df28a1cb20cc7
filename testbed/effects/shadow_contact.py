"""`shadow_contact`: the other contact model's answer on the same states, every step.

The shadow never drives the dynamics. If the scene's contact model is point contact,
the shadow is the static hydroelastic answer (pressure-weighted centre of pressure,
normal, elastic force); otherwise it is the point-contact answer (FCL's deepest
point, normal, depth and the elastic force k * depth). Adds one system,
`shadow_contact_probe`, publishing every time step; rows go to the `shadow` table
with the columns of testbed/contact/extraction.py.
"""


import dataclasses

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.geometry import QueryObject
from pydrake.systems.framework import LeafSystem

from testbed.contact import extraction as contact_extraction
from testbed.contact.body_index import geometry_body_index
from testbed.contact.surfaces import angle_between
from testbed.effects import register
from testbed.effects.base import Effect, Role
from testbed.effects.contact import driving_kind
from testbed.records import TableBuilder


@dataclasses.dataclass
class ShadowContactConfig:
    pass


class ShadowContactProbe(LeafSystem):
    """Evaluates the shadow model on the scene graph's query object every step."""

    def __init__(self, assembly, shadow_kind: str):
        super().__init__()
        self.set_name("shadow_contact_probe")
        self._kind = shadow_kind
        self._assembly = assembly
        self._owner = None
        self._stiffness = None
        self._query_port = self.DeclareAbstractInputPort("query", AbstractValue.Make(QueryObject()))
        assembly.builder.AddSystem(self)
        assembly.builder.Connect(assembly.scene_graph.get_query_output_port(), self._query_port)
        self.DeclarePeriodicPublishEvent(assembly.plant.time_step(), 0.0, self._record)
        self.table = TableBuilder()
        self._h = assembly.plant.time_step()

    def _record(self, context) -> None:
        query = self._query_port.Eval(context)
        if self._owner is None:
            self._owner = geometry_body_index(self._assembly, query)
            self._stiffness = contact_extraction.point_stiffness(query)
        if self._kind == "point":
            columns = contact_extraction.point_pairs_from_query(query, self._owner, self._stiffness)
        else:
            columns = contact_extraction.hydro_surfaces_from_query(query, self._owner)
        self.table.append(int(round(context.get_time() / self._h)), context.get_time(), columns)


def match_rows(truth: dict, other: dict) -> tuple[np.ndarray, np.ndarray]:
    """Indices (i, j) with truth row i and other row j for the same (step, a, b)."""
    n = 1 + int(max(truth["b"].max(initial=0), other["b"].max(initial=0)))
    key_t = (truth["step"] * n + truth["a"]) * n + truth["b"]
    key_o = (other["step"] * n + other["a"]) * n + other["b"]
    _, i, j = np.intersect1d(key_t, key_o, assume_unique=False, return_indices=True)
    return i, j


def disagreement(truth: dict, other: dict) -> dict:
    """Per matched row: CoP distance [m] and normal angle [deg] between two answers."""
    i, j = match_rows(truth, other)
    return {
        "step": truth["step"][i], "a": truth["a"][i], "b": truth["b"][i],
        "cop_distance": np.linalg.norm(truth["p_W_cop"][i] - other["p_W_cop"][j], axis=-1),
        "normal_angle_deg": np.degrees(angle_between(truth["n_W"][i], other["n_W"][j])),
    }


@register
class ShadowContactEffect(Effect):
    name = "shadow_contact"
    Config = ShadowContactConfig
    role = Role.RECORDER
    order = 11
    requires = ("contact",)

    def add_systems(self, assembly) -> list:
        driving = driving_kind(assembly.plan.contact_model)
        self.shadow_kind = "hydroelastic" if driving == "point" else "point"
        self.probe = ShadowContactProbe(assembly, self.shadow_kind)
        return [self.probe]

    def collect(self, tables: dict[str, dict]) -> None:
        tables["shadow"] = self.probe.table.build(contact_extraction.empty_columns())
        if "contacts" in tables:
            tables["shadow_disagreement"] = disagreement(tables["contacts"], tables["shadow"])

    def summarize(self, tables: dict[str, dict]) -> dict:
        out = {"shadow_model": self.shadow_kind, "shadow_rows": int(len(tables["shadow"]["a"]))}
        d = tables.get("shadow_disagreement")
        if d is not None and len(d["step"]):
            worst = int(np.argmax(d["cop_distance"]))
            out.update(
                shadow_cop_distance_median_m=float(np.median(d["cop_distance"])),
                shadow_cop_distance_max_m=float(d["cop_distance"][worst]),
                shadow_worst_step=int(d["step"][worst]),
                shadow_worst_pair=[int(d["a"][worst]), int(d["b"][worst])],
                shadow_normal_angle_max_deg=float(np.max(d["normal_angle_deg"])),
            )
        return out
