"""Meshcat replays of the worst learned scene cases, linked from the report."""

from __future__ import annotations

from pathlib import Path

from testbed.effects import Role, registry
from testbed.records import write_atomic
from testbed.scenario import load_scenario
from testbed.simulation import run_scenario
from testbed.validation.cases.scene import worst_learned


def with_recording(scenario):
    """`scenario` with every recorder, observer and viewer switched on as for a replay
    (each effect's `study_config(replay=True)`: the Meshcat viewer records replay.html)."""
    for name, cls in registry().items():
        if cls.role is not Role.PHYSICS:
            setattr(scenario.effects, name, cls.study_config(replay=True))
    return scenario


def write_worst_replays(run_dir: Path, records: list[dict], n: int) -> None:
    """Re-runs the n worst learned scene cases in this process with the Meshcat
    recording and writes replays/<case id>/replay.html with their records (a replay
    that exists is kept, so --resume does not redo it). Failures are written to
    replays/<case id>/error.txt."""
    for r in worst_learned(records)[:n]:
        out = run_dir / "replays" / r["id"]
        if (out / "replay.html").exists():
            continue
        try:
            p = r["params"]
            scenario = with_recording(load_scenario(p["scene"], overrides=[f"effects.contact.model={p['model']}"]))
            scenario.simulator.target_realtime_rate = 0.0  # as fast as possible
            run_scenario(scenario, out_dir=out, duration=p["duration"], progress=False)  # the effect writes replay.html
        except Exception as e:  # the report says why instead of losing the run
            write_atomic(out / "error.txt", f"{type(e).__name__}: {e}\n")


def replay_links(run_dir: Path) -> dict[str, str]:
    """case id -> replay path relative to run_dir, or why there is none."""
    out = {}
    for p in sorted((run_dir / "replays").glob("*")):
        if not p.is_dir():
            continue
        if (p / "replay.html").exists():
            out[p.name] = f"replays/{p.name}/replay.html"
        else:
            out[p.name] = (p / "error.txt").read_text().strip() if (p / "error.txt").exists() else "missing"
    return out
