"""`testbed run-all`: every shipped scene under each contact model, one summary report.

For each (scene, contact model) two runs are made in this process, side by side:
- *bare*: only the scene's PHYSICS effects (testbed.effects.Role), so the
  real-time factor is that of the simulation itself;
- *recorded*: the same plus every RECORDER effect (contact_log and shadow_contact:
  Drake's own contact, the ground truth), whose records are kept
  under runs/<scene>-<model>/ and whose summary gives penetration and the
  disagreement between the two contact models.
The ratio recorded/bare wall time is what per-step ground-truth logging costs.
"""

from __future__ import annotations

from pathlib import Path

from testbed import variants
from testbed.records import atomic_directory, write_json
from testbed.scenario import load_scenario, shipped_scenes
from testbed.simulation import run_scenario, write_run


def _variant(scenario, *, model: str, recorded: bool):
    """The scene's PHYSICS effects under contact `model`, plus (`recorded`) every RECORDER."""
    return variants.derive(scenario, variants.contact(model), variants.physics_only(), variants.recorders(recorded))


def run_all(out_dir, *, duration=None, models=("hydroelastic", "point"), progress=True) -> str:
    """Runs the batch, writes summary.json / summary.md under out_dir; returns the markdown."""
    rows = []
    scenes = shipped_scenes()
    with atomic_directory(out_dir) as tmp:
        for name, path in scenes.items():
            scenario = load_scenario(path)
            for model in models:
                bare = run_scenario(_variant(scenario, model=model, recorded=False), duration=duration, progress=progress)
                recorded = run_scenario(_variant(scenario, model=model, recorded=True), duration=duration, progress=progress)
                write_run(recorded, Path(tmp) / "runs" / f"{name}-{model}")
                s = recorded.summary
                rows.append({
                    "scene": name, "model": model, "steps": s["steps"],
                    "real_time_factor": bare.summary["real_time_factor"],
                    "ms_per_sim_second": bare.summary["ms_per_sim_second"],
                    "recording_cost_ratio": s["wall_time_s"] / bare.summary["wall_time_s"],
                    "max_penetration_mm": 1e3 * s["max_penetration_m"],
                    "shadow_model": s.get("shadow_model"),
                    "shadow_cop_distance_max_cm": 100 * s.get("shadow_cop_distance_max_m", float("nan")),
                    "shadow_cop_distance_median_cm": 100 * s.get("shadow_cop_distance_median_m", float("nan")),
                    "finite_state": s["finite_state"],
                })
        markdown = _markdown(rows)
        write_json(Path(tmp) / "summary.json", {"schema": "testbed.run_all/1", "rows": rows})
        (Path(tmp) / "summary.md").write_text(markdown)
    return markdown


def _markdown(rows) -> str:
    lines = [
        "# Shipped scenes under each contact model",
        "",
        "Real-time factor of the bare simulation (contact, friction, wind only); recording",
        "cost = wall time with contact_log + shadow_contact over bare. Shadow disagreement =",
        "distance between the driving model's centre of pressure and the shadow model's point.",
        "",
        "| scene | model | steps | real-time factor | ms / sim s | recording cost | max penetration [mm] | shadow | CoP disagreement median / max [cm] |",
        "|---|---|---:|---:|---:|---:|---:|---|---:|",
    ]
    for r in rows:
        lines.append(
            f"| {r['scene']} | {r['model']} | {r['steps']} | {r['real_time_factor']:.2f} | {r['ms_per_sim_second']:.0f} | "
            f"{r['recording_cost_ratio']:.2f}x | {r['max_penetration_mm']:.3f} | {r['shadow_model']} | "
            f"{r['shadow_cop_distance_median_cm']:.1f} / {r['shadow_cop_distance_max_cm']:.1f} |"
        )
    return "\n".join(lines) + "\n"
