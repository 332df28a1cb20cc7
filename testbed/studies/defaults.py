"""`testbed study defaults`: container contact settings judged by evidence (issue 12, section 3).

A setting is (hydroelastic modulus [Pa] on every geometry, discrete approximation,
hydroelastic margin [m], time step [s]). Each setting runs every hard case (the stress
suite's edge_on_edge, corner_on_face, near_parallel tilt 1e-2 and the shipped scene
crane_edge_landing) through `testbed.studies.stability.check`; a SimulationError is a
result ("solver"), not a crash. One row per setting holds the worst figure over its cases
and a verdict per criterion:

- penetration: worst max penetration / the case's bound (pass: <= 1 on every case).
- drift, force balance: the resting cases' figures against stability.RESTING_DRIFT_PER_MINUTE
  and FORCE_BALANCE_TOL ("n/a" when no resting case reached the end without another failure).
- convergence: every case ran to its end (no solver failure, no timeout).
- energy: worst energy gain after first contact / stability's tolerance (pass: <= 1).
- cost: worst wall time per simulated second [s/s], and its ratio to the cheapest setting of
  the same sweep that fails no physics criterion (pass: <= COST_FACTOR). Ratios only mean something within one
  sweep on one machine.

Every (setting, case) pair is independent: they run in a spawn process pool.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import multiprocessing
import time

from testbed.document import Section, Text, table
from testbed.errors import SimulationError

MODULI = (1e8, 3e8, 1e9)  # [Pa]; 1e10 with SAP gives no result within 200 s (issue 12): left out
APPROXIMATIONS = ("sap", "similar", "lagged")
MARGINS = (0.0, 1e-4)  # [m]
TIME_STEPS = (1e-3, 1e-2)  # [s]
CASE_NAMES = ("edge_on_edge", "corner_on_face", "near_parallel", "crane_edge_landing")
COST_FACTOR = 3.0  # [-] more than 3x the cheapest physically sound setting is judged costly
CRANE_PENETRATION_BOUND = 0.02  # [m] the stress suite's bound for edge/corner-first landings
CRITERIA = ("penetration", "drift", "force_balance", "convergence", "energy", "cost")


@dataclasses.dataclass(frozen=True)
class Setting:
    modulus: float  # [Pa] hydroelastic modulus written on every geometry
    approximation: str  # Drake's discrete_contact_approximation
    margin: float  # [m] hydroelastic margin
    time_step: float  # [s]

    @property
    def label(self) -> str:
        return f"E {self.modulus:.0e} / {self.approximation} / margin {self.margin:g} / h {self.time_step:g}"


def grid(quick: bool = False) -> list[Setting]:
    """The settings, most telling first (1 ms, no margin), so a cut-short sweep still says most."""
    if quick:
        return [Setting(1e8, "sap", 0.0, 1e-3), Setting(1e8, "similar", 0.0, 1e-2)]
    full = [Setting(E, a, m, h) for h, m, E, a in itertools.product(TIME_STEPS, MARGINS, MODULI, APPROXIMATIONS)]
    return sorted(full, key=lambda s: (s.margin != 0.0, s.time_step != 1e-3))


def make_case(name: str, setting: Setting, duration: float | None = None):
    """The StressCase `name` under `setting`; duration [s] shortens it (None: the case's own)."""
    from testbed.scenario import load_scenario
    from testbed.studies import stability

    kw = {"approximation": setting.approximation, "time_step": setting.time_step}
    if name == "near_parallel":
        case = stability.near_parallel(1e-2, **kw)
    elif name == "crane_edge_landing":
        base = load_scenario(name)
        s = stability._scenario(name, base.containers, base.duration, model=base.effects.contact.model, **kw)
        s.effects.crane, s.effects.friction = base.effects.crane, base.effects.friction
        case = stability.StressCase(name, s, max_penetration=CRANE_PENETRATION_BOUND, resting=False)
    elif name == "resting_pair":  # a 20 t box settled on a fixed one: the drift/force-balance probe of the tests
        case = stability.near_parallel(0.0, **kw)
        case.scenario.containers[1].V_WC = [0.0] * 6
    else:
        case = stability.CASES[name](**kw)
    case.scenario.effects.contact.hydroelastic_margin = setting.margin
    case.scenario.effects.contact.hydroelastic_modulus = setting.modulus
    if duration is not None:
        case.scenario.duration = duration
    return case


def run_pair(setting: Setting, name: str, duration: float | None = None) -> dict:
    """One (setting, case): stability.check's row plus setting, case kind and wall per sim second."""
    from testbed.studies.stability import check

    case = make_case(name, setting, duration)
    start = time.perf_counter()
    try:
        row = check(case)
    except SimulationError as e:  # built but failed outside the stepping loop
        row = {"stable": False, "failed": f"solver: {e}"[:200]}
    wall = time.perf_counter() - start
    sim_wall = row.get("wall_time_s", wall)  # stepping only when it ran; build + attempt when the solver failed
    return {**row, **dataclasses.asdict(setting), "case_kind": name, "resting": case.resting,
            "duration_s": case.scenario.duration, "wall_per_sim_s": sim_wall / case.scenario.duration}


def _run_pair_args(args):
    return run_pair(*args)


def sweep(settings, cases=CASE_NAMES, *, workers: int = 2, duration: float | None = None,
          deadline_s: float | None = None, on_row=None) -> list[dict]:
    """Runs every (setting, case) in a spawn pool of `workers` processes (1: in this process).

    deadline_s [s of wall]: pairs unfinished by then are rows with failed='timeout' and the
    pool is terminated. on_row(row) is called as each row arrives (to save partial sweeps)."""
    tasks = [(s, c, duration) for s in settings for c in cases]
    rows = []
    if workers <= 1:
        for t in tasks:
            rows.append(run_pair(*t))
            on_row and on_row(rows[-1])
        return rows
    end = None if deadline_s is None else time.monotonic() + deadline_s
    pool = multiprocessing.get_context("spawn").Pool(workers, maxtasksperchild=8)
    try:
        pending = [(t, pool.apply_async(_run_pair_args, (t,))) for t in tasks]
        for t, result in pending:
            try:
                left = None if end is None else max(0.1, end - time.monotonic())
                row = result.get(timeout=left)
            except multiprocessing.TimeoutError:
                row = {**dataclasses.asdict(t[0]), "case_kind": t[1], "stable": False, "failed": "timeout"}
            except Exception as e:  # noqa: BLE001 - a crashed pair is a result too
                row = {**dataclasses.asdict(t[0]), "case_kind": t[1], "stable": False,
                       "failed": f"error: {type(e).__name__}: {e}"[:200]}
            rows.append(row)
            on_row and on_row(row)
    finally:
        pool.terminate()
        pool.join()
    return rows


def _worst(values, default=float("nan")):
    values = [v for v in values if v is not None and not math.isnan(v)]
    return max(values) if values else default


def summarize(rows) -> list[dict]:
    """One row per setting: worst figures over its cases and a verdict per criterion
    ('pass', 'FAIL' or 'n/a'). `failures` lists 'case: reason' for every failing case."""
    from testbed.studies.stability import FORCE_BALANCE_TOL, RESTING_DRIFT_PER_MINUTE

    by_setting = {}
    for r in rows:
        key = Setting(r["modulus"], r["approximation"], r["margin"], r["time_step"])
        by_setting.setdefault(key, []).append(r)
    out = []
    for s, rs in by_setting.items():
        ran = [r for r in rs if "max_penetration_m" in r]
        unconverged = [r for r in rs if "max_penetration_m" not in r]
        resting = [r for r in ran if r.get("resting")]
        pen = _worst(r["max_penetration_m"] / r["penetration_bound_m"] for r in ran)
        drift = _worst(r.get("drift_per_minute_m") for r in resting)
        force = _worst(abs(r["support_force_over_weight"] - 1.0) for r in resting if "support_force_over_weight" in r)
        energy = _worst(r["energy_gain_J"] / r["energy_tolerance_J"] for r in ran)
        out.append({
            **dataclasses.asdict(s), "label": s.label, "cases": len(rs), "converged": len(ran),
            "max_penetration_mm": _worst(r["max_penetration_m"] * 1e3 for r in ran),
            "penetration_over_bound": pen, "drift_mm_per_min": drift * 1e3, "force_balance_error": force,
            "energy_gain_over_tol": energy, "wall_per_sim_s": _worst(r.get("wall_per_sim_s") for r in ran),
            "verdicts": {
                "penetration": _verdict(pen, 1.0) if ran else "n/a",
                "drift": _verdict(drift, RESTING_DRIFT_PER_MINUTE),
                "force_balance": _verdict(force, FORCE_BALANCE_TOL),
                "convergence": "FAIL" if unconverged else "pass",
                "energy": _verdict(energy, 1.0) if ran else "n/a",
            },
            "failures": [f"{r['case_kind']}: {r['failed']}" for r in rs if r.get("failed")],
        })
    # the reference cost: the cheapest setting that fails no physics criterion (else the cheapest converged)
    sound = [o["wall_per_sim_s"] for o in out if "FAIL" not in o["verdicts"].values()]
    converged = [o["wall_per_sim_s"] for o in out if o["verdicts"]["convergence"] == "pass"]
    cheapest = min(sound or converged or [float("nan")])
    for o in out:
        o["cost_ratio"] = o["wall_per_sim_s"] / cheapest if cheapest > 0 else float("nan")
        o["verdicts"]["cost"] = _verdict(o["cost_ratio"], COST_FACTOR)
    return out


def _verdict(value: float, limit: float) -> str:
    return "n/a" if value is None or math.isnan(value) else ("pass" if value <= limit else "FAIL")


def report_sections(summary, wall_s: float | None = None) -> list[Section]:
    """The sweep as document sections: the table (one row per setting) and its key."""
    headers = ["setting", "pen. max [mm]", "pen./bound", "drift [mm/min]", "|F/W-1|", "E gain/tol",
               "wall/sim s", "cost ratio", "converged", *CRITERIA]
    def f(value: float, spec: str) -> str:
        return "-" if math.isnan(value) else format(value, spec)

    rows = [[o["label"], f(o["max_penetration_mm"], ".2f"), f(o["penetration_over_bound"], ".2f"),
             f(o["drift_mm_per_min"], ".3g"), f(o["force_balance_error"], ".2g"), f(o["energy_gain_over_tol"], ".2g"),
             f(o["wall_per_sim_s"], ".2f"), f(o["cost_ratio"], ".2f"), f"{o['converged']}/{o['cases']}",
             *(o["verdicts"][c] for c in CRITERIA)] for o in summary]
    key = (f"Worst figure over the cases of each setting. Bounds: penetration per case (stress suite; "
           f"crane_edge_landing {CRANE_PENETRATION_BOUND * 1e3:g} mm); cost ratio against the cheapest setting "
           f"of this sweep failing no physics criterion (FAIL above {COST_FACTOR:g}x)."
           + (f" Sweep wall time {wall_s:.0f} s." if wall_s is not None else ""))
    failures = [f"{o['label']}: " + "; ".join(o["failures"]) for o in summary if o["failures"]]
    blocks = [Text(key), table(headers, rows)]
    if failures:
        blocks.append(Text("Failures: " + " | ".join(failures)))
    return [Section("Contact defaults sweep", blocks)]
