"""`learned_contact`: the learned predictor's answer next to the ground truth, every step.

Adds one system, `learned_contact_probe`, publishing every time step right after the
contact logger (it needs `contact_log`). For every container-container pair the
logger recorded at that step, it asks the predictor (learned_contact.load_predictor,
pure numpy) for the contact point and normal from the two bodies' poses, in one
batched call per step, and records the `learned` table:

  step, time, a, b     as in the contacts table (A = body a, B = body b)
  p_W_pred (k, 3) [m]  predicted contact point in W
  n_W_pred (k, 3)      predicted unit normal, a -> b, in W
  point_error (k,) [m] |p_W_pred - p_W_cop_static| against the driving model's answer
                       (the pressure-weighted centroid: the definition the predictor is
                       trained for; for point contact, the contact point)
  normal_error_deg (k,) angle between n_W_pred and the driving model's n_W
  shadow_point_error, shadow_normal_error_deg (k,)  the same against the shadow
                       model's answer on the same state (NaN where none)

Pairs with the ground are skipped: the predictor is trained on container pairs. So
are pairs penetrating less than MIN_PENETRATION (boxes placed exactly touching at t = 0):
without elastic pressure the pressure-weighted centre the predictor is trained for is
undefined there.
"""

import dataclasses
import typing

import numpy as np
from pydrake.systems.framework import LeafSystem

from testbed.containers import CONTAINER_TYPES
from testbed.contact_geometry import angle_between, rotation_from_quaternion
from testbed.effects import register
from testbed.effects.base import Effect
from testbed.effects.contact import driving_kind
from testbed.records import TableBuilder


MIN_PENETRATION = 1e-6  # [m]


@dataclasses.dataclass
class LearnedContactConfig:
    weights: typing.Optional[str] = None  # predictor file; None = the shipped default


def _empty() -> dict:
    z3, z = np.zeros((0, 3)), np.zeros(0)
    return {"a": z.astype(int), "b": z.astype(int), "p_W_pred": z3, "n_W_pred": z3, "point_error": z,
            "normal_error_deg": z, "shadow_point_error": z, "shadow_normal_error_deg": z}


class LearnedContactProbe(LeafSystem):
    def __init__(self, assembly, predictor, logger, shadow_probe):
        super().__init__()
        self.set_name("learned_contact_probe")
        self._predictor = predictor
        self._logger = logger
        self._shadow = shadow_probe
        names = assembly.body_names
        size_of = {c.name: CONTAINER_TYPES[c.type].size for c in assembly.scenario.containers}
        self._sizes = np.array([size_of.get(n, (np.nan,) * 3) for n in names])  # (nb, 3) [m]
        self._is_container = np.array([n in size_of for n in names])
        self._last_step = -1
        self.table = TableBuilder()
        assembly.builder.AddSystem(self)
        self.DeclarePeriodicPublishEvent(assembly.plant.time_step(), 0.0, self._on_step)

    def _on_step(self, context) -> None:
        latest = self._logger.contacts.latest()
        if latest is not None and latest[0] > self._last_step:
            self.process(*latest)

    def process(self, step: int, time: float, rows: dict) -> None:
        """Predicts for the container pairs among `rows` (one step of the contacts table)."""
        self._last_step = step
        keep = self._is_container[rows["a"]] & self._is_container[rows["b"]] & (rows["phi"] < -MIN_PENETRATION)
        if not np.any(keep):
            return
        a, b = rows["a"][keep], rows["b"][keep]
        R_WA, R_WB = rotation_from_quaternion(rows["q_WA"][keep]), rotation_from_quaternion(rows["q_WB"][keep])
        p_WA = rows["p_WA"][keep]
        R_AW = np.transpose(R_WA, (0, 2, 1))
        p_AB = np.einsum("nij,nj->ni", R_AW, rows["p_WB"][keep] - p_WA)  # (k, 3) in A [m]
        R_AB = R_AW @ R_WB  # (k, 3, 3)
        point_A, normal_A = self._predictor.predict(p_AB, R_AB, size_A=self._sizes[a], size_B=self._sizes[b])
        p_W = p_WA + np.einsum("nij,nj->ni", R_WA, point_A)
        n_W = np.einsum("nij,nj->ni", R_WA, normal_A)
        columns = {
            "a": a, "b": b, "p_W_pred": p_W, "n_W_pred": n_W,
            "point_error": np.linalg.norm(p_W - rows["p_W_cop_static"][keep], axis=1),
            "normal_error_deg": np.degrees(angle_between(n_W, rows["n_W"][keep])),
        }
        columns.update(self._against_shadow(step, a, b, p_W, n_W))
        self.table.append(step, time, columns)

    def _against_shadow(self, step, a, b, p_W, n_W) -> dict:
        point_error = np.full(len(a), np.nan)
        normal_error = np.full(len(a), np.nan)
        if self._shadow is not None:
            for chunk in self._shadow.table.chunks_for_step(step):
                for i, (ai, bi) in enumerate(zip(a, b)):
                    match = np.flatnonzero((chunk["a"] == ai) & (chunk["b"] == bi))
                    if match.size:
                        j = match[0]
                        point_error[i] = np.linalg.norm(p_W[i] - chunk["p_W_cop_static"][j])
                        normal_error[i] = np.degrees(angle_between(n_W[i], chunk["n_W"][j]))
        return {"shadow_point_error": point_error, "shadow_normal_error_deg": normal_error}


def summarize_errors(table: dict, prefix: str = "learned") -> dict:
    """Median, p95, max and worst step of the point [m] and normal [deg] errors."""
    out = {f"{prefix}_rows": int(len(table["a"]))}
    for column, unit in (("point_error", "m"), ("normal_error_deg", "deg"),
                         ("shadow_point_error", "m"), ("shadow_normal_error_deg", "deg")):
        values = table[column]
        finite = np.isfinite(values)
        if not np.any(finite):
            continue
        v = values[finite]
        worst = int(np.flatnonzero(finite)[np.argmax(v)])
        name = column.replace("_deg", "")
        out.update({
            f"{prefix}_{name}_median_{unit}": float(np.median(v)),
            f"{prefix}_{name}_p95_{unit}": float(np.percentile(v, 95)),
            f"{prefix}_{name}_max_{unit}": float(v.max()),
            f"{prefix}_{name}_worst_step": int(table["step"][worst]),
        })
    return out


@register
class LearnedContactEffect(Effect):
    name = "learned_contact"
    Config = LearnedContactConfig
    order = 30
    requires = ("contact", "contact_log")

    def add_systems(self, assembly) -> list:
        from learned_contact import load_predictor  # numpy-only inference; no torch

        predictor = load_predictor(self.config.weights) if self.config.weights else load_predictor()
        logger = assembly.effects["contact_log"].logger
        shadow = assembly.effects.get("shadow_contact")
        self.probe = LearnedContactProbe(assembly, predictor, logger, shadow.probe if shadow else None)
        return [self.probe]

    def collect(self, tables: dict) -> None:
        # rows the logger appended after the probe's last publish (the final step)
        for chunk in self.probe._logger.contacts.chunks_after_step(self.probe._last_step):
            self.probe.process(int(chunk["step"][0]), float(chunk["time"][0]), chunk)
        tables["learned"] = self.probe.table.build(_empty())

    def summarize(self, tables: dict) -> dict:
        """Error figures against the driving model and the shadow, plus `learned_vs_hydro_*`:
        against the hydroelastic answer the predictor is trained for (the driving model's
        when it is hydroelastic, the shadow's when the scene drives with point contact)."""
        table = tables["learned"]
        out = summarize_errors(table)
        driving = driving_kind(self.scenario.effects.contact.model)
        source = "" if driving == "hydroelastic" else "shadow_"
        hydro = {"a": table["a"], "step": table["step"],
                 "point_error": table[f"{source}point_error"], "normal_error_deg": table[f"{source}normal_error_deg"],
                 "shadow_point_error": np.full(len(table["a"]), np.nan),
                 "shadow_normal_error_deg": np.full(len(table["a"]), np.nan)}
        out.update(summarize_errors(hydro, prefix="learned_vs_hydro"))
        return out
