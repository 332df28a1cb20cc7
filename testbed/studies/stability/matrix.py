"""Hard cases and their stability verdicts: the stress suite and the stability matrix.

Each stress case is a function returning a Scenario (built in code, so the grid can
vary contact model, approximation and time step); `check` simulates it with the
contact log and judges it against stated criteria. The pytest stress suite
(tests/physics/test_stress.py) and `testbed study stability` share these definitions.

Criteria (with why):
- finite: no NaN or inf in the state.
- energy: after the first contact, mechanical energy (kinetic + gravity) never
  exceeds its value at first contact by more than ENERGY_TOLERANCE x m_total g x 1 m;
  this leaves room for the elastic energy stored in the contact compression (order
  0.5 F d ~ 1e2 J for 30 t at 0.5 mm) to reappear as motion, nothing more.
- penetration: the largest penetration at any step stays below the case's bound.
- drift (resting cases): horizontal drift of every free container over the last
  quarter of the run, scaled to a minute, below RESTING_DRIFT_PER_MINUTE.
- force balance (resting cases): the mean normal force on the supports over the last
  0.2 s equals the weight within FORCE_BALANCE_TOL.
"""

import dataclasses
import math

import numpy as np
from pydrake.common.schema import Rotation, Transform

from testbed import variants
from testbed.bodies.containers import CONTAINER_TYPES, HYDROELASTIC_MODULUS
from testbed.bodies.models import GROUND_NAME
from testbed.drake_support import available
from testbed.errors import SimulationError
from testbed.physics import GRAVITY
from testbed.scenario import ContainerSpec, Scenario, load_scenario
from testbed.simulation import run_scenario

ENERGY_TOLERANCE = 1e-3  # [-] of m_total g x 1 m
RESTING_DRIFT_PER_MINUTE = 1e-3  # [m]
FORCE_BALANCE_TOL = 0.01  # [-]
H_20 = CONTAINER_TYPES["1CC"].size[2]


@dataclasses.dataclass
class StressCase:
    name: str
    scenario: Scenario
    max_penetration: float  # [m] bound for this case
    resting: bool  # judged for drift and force balance at the end
    support: str = GROUND_NAME  # body whose contacts carry the weight at rest (resting cases)


def _scenario(name, containers, duration, *, model="hydroelastic", approximation="auto", time_step=1e-3,
              ground=True) -> Scenario:
    s = Scenario(name=name, description=name, duration=duration, ground=ground, containers=containers)
    return variants.derive(s, variants.timing(time_step=time_step), variants.contact(model, approximation),
                           variants.log_contacts())


def _box(name, z, *, type="1CC", mass=20000.0, rpy_deg=(0.0, 0.0, 0.0), xy=(0.0, 0.0), v_z=0.0, fixed=False):
    from pydrake.math import RollPitchYaw

    X = Transform(translation=[xy[0], xy[1], z], rotation=Rotation(RollPitchYaw(np.radians(rpy_deg))))
    return ContainerSpec(name=name, type=type, mass=mass, X_WC=X, V_WC=[0, 0, 0, 0, 0, v_z], fixed=fixed)


def _lowest_offset(type: str, rpy_deg) -> float:
    """Depth [m] of a rotated box's lowest point below its centre."""
    from pydrake.math import RollPitchYaw, RotationMatrix

    R = RotationMatrix(RollPitchYaw(np.radians(rpy_deg))).matrix()
    return float(np.abs(R[2]) @ CONTAINER_TYPES[type].half_size)


def near_parallel(tilt: float, **kw) -> StressCase:
    """A 20 t box landing at 0.3 m/s on a fixed one, tilted by `tilt` [rad] about x."""
    rpy = (math.degrees(tilt), 0.0, 0.0)
    z = H_20 + 2e-3 + _lowest_offset("1CC", rpy)
    boxes = [_box("lower", H_20 / 2, fixed=True), _box("upper", z, rpy_deg=rpy, v_z=-0.3)]
    return StressCase(f"near_parallel_{tilt:g}", _scenario(f"near_parallel_{tilt:g}", boxes, 2.0, **kw),
                      max_penetration=5e-3, resting=True, support="lower")


def edge_on_edge(**kw) -> StressCase:
    """The upper box rolled 45 deg and yawed 90 deg: its bottom edge lands across the lower's top."""
    rpy = (45.0, 0.0, 90.0)
    z = H_20 + 2e-3 + _lowest_offset("1CC", rpy)
    boxes = [_box("lower", H_20 / 2, fixed=True), _box("upper", z, rpy_deg=rpy, v_z=-0.3)]
    return StressCase("edge_on_edge", _scenario("edge_on_edge", boxes, 0.5, **kw), max_penetration=0.02, resting=False)


def corner_on_face(**kw) -> StressCase:
    """The upper box rolled 35 deg and pitched 30 deg: a corner lands on the lower's top face."""
    rpy = (35.0, 30.0, 0.0)
    z = H_20 + 2e-3 + _lowest_offset("1CC", rpy)
    boxes = [_box("lower", H_20 / 2, fixed=True), _box("upper", z, rpy_deg=rpy, v_z=-0.3)]
    return StressCase("corner_on_face", _scenario("corner_on_face", boxes, 0.5, **kw), max_penetration=0.02, resting=False)


def mass_ratio(heavy: float, light: float, heavy_type: str = "1CC", **kw) -> StressCase:
    """A `heavy` [kg] container resting on a `light` [kg] one on the quay."""
    h_heavy = CONTAINER_TYPES[heavy_type].size[2]
    boxes = [_box("light", H_20 / 2, mass=light), _box("heavy", H_20 + h_heavy / 2, type=heavy_type, mass=heavy)]
    name = f"mass_ratio_{heavy / light:.0f}"
    return StressCase(name, _scenario(name, boxes, 1.0, **kw), max_penetration=5e-3, resting=True)


def drop_on_stack(speed: float = 2.0, **kw) -> StressCase:
    """A 20 t container hitting a resting 2-stack at `speed` [m/s] (from 5 mm above)."""
    boxes = [_box("tier1", H_20 / 2, mass=25000.0), _box("tier2", 1.5 * H_20, mass=20000.0),
             _box("falling", 2.5 * H_20 + 5e-3, v_z=-speed)]
    return StressCase(f"drop_{speed:g}ms_on_stack", _scenario(f"drop_{speed:g}ms_on_stack", boxes, 1.0, **kw),
                      max_penetration=0.05, resting=False)


def resting_stack(scene: str = "nine_mixed_stack", duration: float = 60.0, **kw) -> StressCase:
    """A shipped stack resting; logged every 10 ms (rest is judged on slow quantities)."""
    base = load_scenario(scene)
    s = variants.derive(_scenario(f"{scene}_{duration:g}s", base.containers, duration, **kw),
                        variants.log_contacts(None))  # every records.RECORD_PERIOD
    return StressCase(s.name, s, max_penetration=5e-3, resting=True)


def wobble(time_step: float, mass: float = 2200.0, margin: float = 0.0, duration: float = 1.0, **kw) -> StressCase:
    """Drake's wobble protocol (contact_model_doxygen.h): a box resting on a fixed box.

    The figure of merit is sigma(|phi|) / (h^2 g) against h sqrt(k / m), with
    k = E A / (half the smallest side) of the pair; it is reported by `wobble_figures`.
    """
    rpy = (0.1, 0.0, 0.0)  # a 0.1 deg tilt, released 1 mm above: it lands on one edge first
    boxes = [_box("lower", H_20 / 2, fixed=True),
             _box("upper", H_20 + 1e-3 + _lowest_offset("1CC", rpy), mass=mass, rpy_deg=rpy)]
    s = variants.derive(_scenario(f"wobble_h{time_step:g}_m{mass:g}_margin{margin:g}", boxes, duration,
                                  time_step=time_step, **kw), variants.contact_params(margin=margin))
    return StressCase(s.name, s, max_penetration=5e-3, resting=True, support="lower")


def wobble_figures(case: StressCase, result) -> dict:
    """sigma(|phi|)/(h^2 g) over the second half, and h sqrt(k/m) (k in series for the pair)."""
    h = case.scenario.plant.time_step
    c = result.tables["contacts"]
    late = c["time"] >= c["time"].max() / 2
    phi = np.abs(c["phi"][late])
    ctype = CONTAINER_TYPES["1CC"]
    modulus = case.scenario.effects.contact.hydroelastic_modulus or HYDROELASTIC_MODULUS  # [Pa] on both boxes
    k_one = modulus * ctype.footprint_area / (min(ctype.size) / 2)  # E A / (half the smallest side) [N/m]
    k = k_one / 2  # two equal compliant boxes in series
    mass = case.scenario.containers[1].total_mass()
    return {"sigma_phi_over_h2g": float(np.std(phi) / (h * h * GRAVITY)) if phi.size else float("nan"),
            "h_sqrt_k_over_m": h * math.sqrt(k / mass)}


CASES = {
    "near_parallel": near_parallel, "edge_on_edge": edge_on_edge, "corner_on_face": corner_on_face,
    "mass_ratio": mass_ratio, "drop_on_stack": drop_on_stack, "resting_stack": resting_stack, "wobble": wobble,
}


MATRIX_APPROXIMATIONS = ("sap", "tamsi", "lagged")  # the approximation axis (Drake's names)


def matrix_cases(quick: bool = False, approximations=None) -> list[tuple[str, dict]]:
    """The sampled grid: (case factory name, keyword arguments) pairs.

    Every case runs at the baseline (hydroelastic, auto = similar, 1 ms: the shipped defaults);
    each axis is then varied alone: contact model (point, hydroelastic_with_fallback),
    approximation (`approximations`; None: MATRIX_APPROXIMATIONS less what the installed Drake
    lacks, i.e. no tamsi from Drake 1.57 on) and time step (1e-4 for the short cases, 1e-2).
    """
    if approximations is None:
        approximations = available(MATRIX_APPROXIMATIONS)
    # the quick grid varies the approximation once: TAMSI, or lagged where Drake has no TAMSI
    quick_pick = next((a for a in ("tamsi", "lagged") if a in approximations), None)
    bases = [("near_parallel", {"tilt": t}) for t in ((1e-5, 1e-3, 1e-1) if quick else (1e-5, 1e-4, 1e-3, 1e-2, 1e-1))]
    bases += [("edge_on_edge", {}), ("corner_on_face", {}), ("mass_ratio", {"heavy": 32500.0, "light": 2200.0, "heavy_type": "1AAA"}),
              ("mass_ratio", {"heavy": 32500.0, "light": 32.5}), ("drop_on_stack", {"speed": 2.0})]
    grid = []
    for name, kw in bases:
        grid.append((name, kw))
        for model in ("point", "hydroelastic_with_fallback"):
            grid.append((name, {**kw, "model": model}))
        for approximation in approximations:
            if quick and approximation != quick_pick:
                continue
            grid.append((name, {**kw, "approximation": approximation}))
        grid.append((name, {**kw, "time_step": 1e-2}))
        if not quick and name in ("edge_on_edge", "corner_on_face"):
            grid.append((name, {**kw, "time_step": 1e-4}))
    for h in ((1e-3, 1e-2) if quick else (1e-3, 3e-3, 5e-3, 1e-2)):
        for margin in (0.0, 1e-4):
            grid.append(("wobble", {"time_step": h, "margin": margin}))
    return grid


def run_matrix_entry(name: str, kw: dict) -> dict:
    """One grid entry: the verdict row (with wobble figures for wobble cases)."""
    case = CASES[name](**kw)
    row = check(case)
    row["case_kind"] = name
    row["params"] = {k: v for k, v in kw.items() if k not in ("model", "approximation", "time_step")}
    return row


def check(case: StressCase) -> dict:
    """Simulates a case and returns its figures and verdicts ({'stable': bool, ...})."""
    scenario = case.scenario
    out = {"case": case.name, "model": scenario.effects.contact.model,
           "approximation": scenario.effects.contact.approximation, "time_step": scenario.plant.time_step}
    try:
        result = run_scenario(scenario)
    except SimulationError as e:
        return {**out, "stable": False, "failed": f"solver: {str(e).split(': ', 2)[-1][:160]}"}
    steps, contacts = result.tables["steps"], result.tables["contacts"]
    masses = np.array([c.total_mass() for c in scenario.containers if not c.fixed])
    figures = {"wall_time_s": result.summary["wall_time_s"], "finite": result.summary["finite_state"]}
    energy = steps["kinetic_energy"] + steps["potential_energy"]
    if len(contacts["step"]):
        first = int(np.searchsorted(steps["step"], contacts["step"].min()))  # row of the first contact
        figures["energy_gain_J"] = float(np.max(energy[first:] - energy[first]))
    else:
        figures["energy_gain_J"] = 0.0
    figures["energy_tolerance_J"] = ENERGY_TOLERANCE * masses.sum() * GRAVITY * 1.0
    figures["max_penetration_m"] = float(max(0.0, -np.nanmin(contacts["phi"]))) if len(contacts["phi"]) else 0.0
    figures["penetration_bound_m"] = case.max_penetration
    failures = []
    if not figures["finite"] or not np.all(np.isfinite(steps["p_WB"])):
        failures.append("non-finite state")
    if figures["energy_gain_J"] > figures["energy_tolerance_J"]:
        failures.append(f"energy grew by {figures['energy_gain_J']:.3g} J after first contact")
    if figures["max_penetration_m"] > case.max_penetration:
        failures.append(f"penetration {figures['max_penetration_m'] * 1e3:.2f} mm > {case.max_penetration * 1e3:g} mm")
    if case.resting and not failures:
        t = steps["time"]
        half = np.searchsorted(t, 0.75 * t[-1])  # the last quarter: after landing and settling
        drift = np.max(np.linalg.norm(steps["p_WB"][-1, :, :2] - steps["p_WB"][half, :, :2], axis=-1))
        figures["drift_per_minute_m"] = float(drift * 60.0 / max(t[-1] - t[half], 1e-9))
        if figures["drift_per_minute_m"] > RESTING_DRIFT_PER_MINUTE:
            failures.append(f"drift {figures['drift_per_minute_m'] * 1e3:.2f} mm/min")
        support = result.body_names.index(case.support)
        late = (contacts["time"] >= contacts["time"].max() - 0.2) & (contacts["a"] == support)
        n_steps = np.unique(contacts["step"][late]).size
        carried = masses.sum() * GRAVITY
        figures["support_force_over_weight"] = float(contacts["fn"][late].sum() / max(n_steps, 1) / carried)
        if abs(figures["support_force_over_weight"] - 1.0) > FORCE_BALANCE_TOL:
            failures.append(f"support force {figures['support_force_over_weight']:.4f} x weight")
    if case.name.startswith("wobble"):
        figures.update(wobble_figures(case, result))
    return {**out, **figures, "stable": not failures, "failed": "; ".join(failures)}


def stability_matrix(rows) -> tuple[list[str], list[list[str]]]:
    """(column labels, rows) of the matrix: case x (model, approximation, time step).

    rows: run_matrix_entry results; a cell is "stable" or names the failed criterion."""
    columns, table = [], {}
    for r in rows:
        column = f"{r['model']} / {r['approximation']} / {r['time_step']:g} s"
        if column not in columns:
            columns.append(column)
        cell = "stable" if r["stable"] else f"UNSTABLE: {r['failed']}"
        if r["case"].startswith("wobble"):
            cell += f" (sigma/h2g {r.get('sigma_phi_over_h2g', float('nan')):.3g} at h sqrt(k/m) {r.get('h_sqrt_k_over_m', float('nan')):.2f})"
        table.setdefault(r["case"], {})[column] = cell
    return columns, [[case] + [cells.get(c, "") for c in columns] for case, cells in table.items()]
