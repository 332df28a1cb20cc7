"""The `sim` study: whole simulations of one scene, cost against accuracy (time step x contact
model x discrete approximation), and what each effect costs (runs.py: sweep, effect_costs).

`from testbed.studies.sim import sweep, effect_costs, ...` keeps working: the names of runs.py
are read from it on first use (this `__init__` stays light for the CLI's parser).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

from testbed.drake_support import available
from testbed.records import write_atomic
from testbed.studies import register
from testbed.studies.base import Study

QUICK_STEPS = (1e-3, 3e-3, 1e-2)  # [s]
FULL_STEPS = (2e-4, 5e-4, 1e-3, 2e-3, 5e-3, 1e-2)  # [s]


@dataclasses.dataclass
class SimConfig:
    """scene: a shipped scene's name or a file; time_steps [s] of the sweep, against a
    reference_step [s] run of each model and approximation; duration [s] of each sweep run;
    effects_duration [s] of each effect-cost run; progress: progress bars."""

    scene: str = "two_stack"
    time_steps: list[float] = dataclasses.field(default_factory=lambda: list(FULL_STEPS))
    reference_step: float = 1e-4
    duration: float = 1.0
    effects_duration: float = 1.0
    progress: bool = True


def _code():
    """runs.py, imported on first use (it imports pydrake)."""
    from testbed.studies.sim import runs

    return runs


@register
class SimStudy(Study):
    name = "sim"
    help = "time step x contact model x approximation on one scene, and what each effect costs"
    order = 10
    Config = SimConfig

    def add_arguments(self, group) -> None:
        group.add_argument("--scene", default="two_stack", help="scene of the sim study (default two_stack)")

    def configure(self, args) -> SimConfig:
        quick = bool(args.quick)
        return SimConfig(scene=args.scene, time_steps=list(QUICK_STEPS if quick else FULL_STEPS),
                         duration=0.5 if quick else 1.0, effects_duration=0.3 if quick else 1.0, progress=not args.quiet)

    def run(self, config: SimConfig, out: Path, map_calls=None) -> dict:
        runs = _code()
        rows = runs.sweep(config.scene, models=["hydroelastic", "point"],
                          approximations=available(("sap", "tamsi", "similar", "lagged")),
                          time_steps=list(config.time_steps), reference_step=config.reference_step,
                          duration=config.duration, progress=config.progress)
        costs = runs.effect_costs(config.scene, duration=config.effects_duration)
        return {"sweep": rows, "effect_costs": costs}

    def report(self, result: dict, out: Path) -> list[Path]:
        Path(out).mkdir(parents=True, exist_ok=True)
        return [write_atomic(Path(out) / "sim.json", json.dumps(result, indent=1))]

    def summary(self, result: dict) -> list[str]:
        lines = [f"{r['model']:13s} {r['approximation']:7s} h={r['time_step']:<7g} {r['ms_per_sim_second']:8.0f} ms/sim s  "
                 f"deviation {r['deviation_m'] * 1e3:9.3f} mm  {r['status']}" for r in result["sweep"]]
        lines += [f"effect {r['effect']:16s} " + (f"{r['ratio']:.2f}x" if r.get("status") == "ok" else str(r.get("status")))
                  for r in result["effect_costs"]]
        return lines


def __getattr__(name):
    if name.startswith("__") or name == "runs":  # the submodule itself: imported, not forwarded
        raise AttributeError(name)
    return getattr(_code(), name)
