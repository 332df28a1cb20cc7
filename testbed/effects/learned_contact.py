"""`learned_contact`: the learned predictor's answer next to the ground truth, every step.

Adds one system, `learned_contact_probe`, publishing every time step (it needs
`contact_log`). For every container-container pair the logger recorded at each step
(ContactLogger.contacts_after), it asks the predictor (learned_contact.load_predictor:
"improved", "paper" or a weights path; compiled) for the contact point and normal from
the two bodies' poses, one batched call per BATCH_STEPS recorded steps, and records the
`learned` table, one row per pair per step:

  step, time, a, b     as in the contacts table (A = body a, B = body b)
  p_W_pred (k, 3) [m]  predicted contact point in W
  n_W_pred (k, 3)      predicted unit normal, a -> b, in W
  point_error (k,) [m] |p_W_pred - p_W_cop_static| against the driving model's answer
                       (the exact centre of pressure of Drake's pressure field: the definition
                       the predictor is trained for; for point contact, the contact point);
                       NaN where the logger's static columns are held from an earlier step
                       (static_age > 0, see contact_log's static_every_steps)
  one_point_error (k,) [m] |p_W_pred - p_W_cop_one_point|: against Drake's one-point rule
                       (what Drake's discrete solver applies; the second reference)
  truth_gap (k,) [m]   |p_W_cop_static - p_W_cop_one_point|: the truth's own discretisation
                       error at this row (0 for point contact); NaN like point_error
  normal_error_deg (k,) angle between n_W_pred and the driving model's n_W (NaN likewise)
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

from learned_contact import WeightsError, load_predictor  # native-core inference; no torch
from learned_contact.interface import SIZE_TOLERANCE
from testbed.contact.surfaces import angle_between
from testbed.effects import register
from testbed.effects.base import Effect, Role
from testbed.effects.contact import driving_kind
from testbed.records import TableBuilder

MIN_PENETRATION = 1e-6  # [m]
# Recorded steps predicted per predictor call: one batched call amortises the per-call
# cost; the `learned` rows lag the simulation by at most this many steps until collect().
# A scene with a live viewer (the meshcat effect) gets every step's answer on time (1).
BATCH_STEPS = 10


@dataclasses.dataclass
class LearnedContactConfig:
    # the predictor: any learned_contact.sources spec ("improved", the shipped default when
    # None; "paper"; a weights .npz; an ONNX model; module:attribute)
    predictor: typing.Optional[str] = None


def _empty() -> dict:
    z3, z = np.zeros((0, 3)), np.zeros(0)
    return {"a": z.astype(int), "b": z.astype(int), "p_W_pred": z3, "n_W_pred": z3, "point_error": z,
            "one_point_error": z, "truth_gap": z, "normal_error_deg": z, "shadow_point_error": z, "shadow_normal_error_deg": z}


class LearnedContactProbe(LeafSystem):
    def __init__(self, assembly, predictor, logger, shadow_probe, batch_steps: int = BATCH_STEPS):
        super().__init__()
        self.set_name("learned_contact_probe")
        self._predictor = predictor
        self._logger = logger
        self._shadow = shadow_probe
        names = assembly.body_names
        size_of = {c.name: c.container_type().size for c in assembly.scenario.containers}
        self._sizes = np.array([size_of.get(n, (np.nan,) * 3) for n in names])  # (nb, 3) [m]
        self._is_container = np.array([n in size_of for n in names])
        self.last_step = -1  # the last contacts step processed
        self._batch = batch_steps
        self.table = TableBuilder()
        assembly.builder.AddSystem(self)
        self.DeclarePeriodicPublishEvent(assembly.plant.time_step(), 0.0, self._on_step)

    def _on_step(self, context) -> None:
        latest = self._logger.latest_contacts()
        # a batch of BATCH_STEPS recorded steps per predictor call (publish order within one
        # time is not fixed, so the steps are read from the logger, never assumed)
        if latest is not None and latest[0] - self.last_step >= self._batch:
            self.catch_up()

    def catch_up(self) -> None:
        """Predicts for every step the logger recorded since the last call, in one batch."""
        self.process_steps(self._logger.contacts_after(self.last_step))

    def process(self, step: int, time: float, rows: dict) -> None:
        """Predicts for the container pairs among `rows` (one step of the contacts table)."""
        self.process_steps([(step, time, rows)])

    def process_steps(self, steps: list) -> None:
        """Predicts for the container pairs among [(step, time, rows)] (steps of the
        contacts table, oldest first) with one predictor call, and appends one chunk per step."""
        if not steps:
            return
        self.last_step = steps[-1][0]
        names = ("a", "b", "phi", "p_WA", "R_WA", "p_WB", "R_WB", "p_W_cop_static", "p_W_cop_one_point", "n_W",
                 "static_age")
        rows = {k: np.concatenate([r[k] for _, _, r in steps]) for k in names}
        owner = np.repeat(np.arange(len(steps)), [len(r["a"]) for _, _, r in steps])  # row -> index in steps
        keep = self._is_container[rows["a"]] & self._is_container[rows["b"]] & (rows["phi"] < -MIN_PENETRATION)
        if not np.any(keep):
            return
        a, b, owner = rows["a"][keep], rows["b"][keep], owner[keep]
        R_WA, R_WB = rows["R_WA"][keep], rows["R_WB"][keep]
        p_WA = rows["p_WA"][keep]
        R_AW = np.transpose(R_WA, (0, 2, 1))
        p_AB = np.einsum("nij,nj->ni", R_AW, rows["p_WB"][keep] - p_WA)  # (k, 3) in A [m]
        R_AB = R_AW @ R_WB  # (k, 3, 3)
        point_A, normal_A = self._predictor.predict(p_AB, R_AB, size_A=self._sizes[a], size_B=self._sizes[b])
        p_W = p_WA + np.einsum("nij,nj->ni", R_WA, point_A)
        n_W = np.einsum("nij,nj->ni", R_WA, normal_A)
        fresh = rows["static_age"][keep] == 0  # static columns computed on this state
        columns = {
            "a": a, "b": b, "p_W_pred": p_W, "n_W_pred": n_W,
            "point_error": np.where(fresh, np.linalg.norm(p_W - rows["p_W_cop_static"][keep], axis=1), np.nan),
            "one_point_error": np.where(fresh, np.linalg.norm(p_W - rows["p_W_cop_one_point"][keep], axis=1), np.nan),
            "truth_gap": np.where(fresh, np.linalg.norm(rows["p_W_cop_static"][keep] - rows["p_W_cop_one_point"][keep],
                                                        axis=1), np.nan),
            "normal_error_deg": np.where(fresh, np.degrees(angle_between(n_W, rows["n_W"][keep])), np.nan),
        }
        bounds = np.searchsorted(owner, np.arange(len(steps) + 1))
        for i, (step, time, _) in enumerate(steps):
            lo, hi = bounds[i], bounds[i + 1]
            if hi > lo:
                chunk = {k: v[lo:hi] for k, v in columns.items()}
                chunk.update(self._against_shadow(step, chunk["a"], chunk["b"], chunk["p_W_pred"], chunk["n_W_pred"]))
                self.table.append(step, time, chunk)

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
    for column, unit in (("point_error", "m"), ("one_point_error", "m"), ("truth_gap", "m"), ("normal_error_deg", "deg"),
                         ("shadow_point_error", "m"), ("shadow_normal_error_deg", "deg")):
        values = table.get(column)
        if values is None:
            continue
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
    role = Role.OBSERVER
    order = 30
    requires = ("contact", "contact_log")

    def add_systems(self, assembly) -> list:
        try:
            predictor = load_predictor(self.config.predictor)
        except WeightsError as e:
            raise self.fail("predictor", str(e)) from None
        self._check_sizes(predictor)
        logger = assembly.effects["contact_log"].logger
        shadow = assembly.effects.get("shadow_contact")
        live = getattr(self.scenario.effects, "meshcat", None) is not None  # draws each step as it happens
        self.probe = LearnedContactProbe(assembly, predictor, logger, shadow.probe if shadow else None,
                                         batch_steps=1 if live else BATCH_STEPS)
        return [self.probe]

    def _check_sizes(self, predictor) -> None:
        """A scene body the predictor was not trained for (e.g. a generic box) fails at build
        time with the entry and the supported sizes named, not mid-run."""
        supported = np.asarray(predictor.supported_sizes, dtype=float).reshape(-1, 3)
        for i, c in enumerate(self.scenario.containers):
            size = np.asarray(c.container_type().size, dtype=float)
            if np.abs(supported - size).max(axis=1).min() > SIZE_TOLERANCE:
                choices = "; ".join(str(tuple(float(v) for v in s)) for s in supported)
                raise self.fail("", f"containers[{i}] ({c.name!r}, type {c.type}, size {tuple(float(v) for v in size)} m) "
                                    f"is not a size the learned predictor supports (full extents [m]: {choices}); "
                                    "remove effects.learned_contact or use a supported size")

    @property
    def predictions(self):
        """The `learned` rows as they are recorded (a records.TableBuilder; None before
        the scene is built); the Meshcat overlay reads it."""
        probe = getattr(self, "probe", None)
        return probe.table if probe is not None else None

    def collect(self, tables: dict) -> None:
        self.probe.catch_up()
        tables["learned"] = self.probe.table.build(_empty())

    def summarize(self, tables: dict) -> dict:
        """Error figures against the driving model and the shadow, plus `learned_vs_hydro_*`:
        against the hydroelastic answer the predictor is trained for (the driving model's
        when it is hydroelastic, the shadow's when the scene drives with point contact)."""
        table = tables["learned"]
        out = summarize_errors(table)
        driving = driving_kind(self.scenario.effects.contact.model)
        source = "" if driving == "hydroelastic" else "shadow_"
        nan = np.full(len(table["a"]), np.nan)
        hydro = {"a": table["a"], "step": table["step"],
                 "point_error": table[f"{source}point_error"], "normal_error_deg": table[f"{source}normal_error_deg"],
                 # the one-point reference and the truth's gap: on the driving model's rows (the shadow keeps none)
                 "one_point_error": table["one_point_error"] if not source else nan,
                 "truth_gap": table["truth_gap"] if not source else nan,
                 "shadow_point_error": np.full(len(table["a"]), np.nan),
                 "shadow_normal_error_deg": np.full(len(table["a"]), np.nan)}
        out.update(summarize_errors(hydro, prefix="learned_vs_hydro"))
        return out
