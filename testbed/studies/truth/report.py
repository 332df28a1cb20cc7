"""The truth study's outputs: truth.json (everything run.run_study returns, machine-readable)
and truth.md (per scene: the rungs' quantities and wall times, the GCIs, the classification),
written atomically (testbed.records.write_atomic) like the other studies'."""

from __future__ import annotations

import json
from pathlib import Path

from testbed.document import Section, Text, table, to_markdown
from testbed.records import json_default, write_atomic


def _fmt(value, digits: int = 6) -> str:
    if value is None:
        return "-"
    if isinstance(value, bool):
        return "yes" if value else "NO"
    if isinstance(value, float):
        return f"{value:.{digits}g}"
    return str(value)


def scene_sections(scene: dict) -> list[Section]:
    """Three tables of one scene: the rungs (status, wall), the quantities per rung, the GCIs."""
    rows = scene["rungs"]
    rung_table = table(["rung", "status", "h [s]", "build [s]", "wall [s]", "wall per sim s [s]", "error"],
                       [[n, r["status"], _fmt(r["time_step_s"]), _fmt(r["build_s"], 3), _fmt(r["wall_s"], 3),
                         _fmt(r["wall_per_sim_s"], 3), r["error"][:120]] for n, r in rows.items()])
    names = list(rows)
    quantity_rows = [[q, *[_fmt(e["values"].get(n)) for n in names]] for q, e in scene["quantities"].items()]
    gci_rows = []
    for q, e in scene["quantities"].items():
        mesh, acc = e["mesh_gci"], e["accuracy_gci"]
        gci_rows.append([q, _fmt(mesh["p"], 3), _fmt(mesh["fs"]), _fmt(mesh["gci_abs"], 3), mesh["behaviour"],
                         _fmt(acc["gci_abs"], 3) if acc else "-", acc["behaviour"] if acc else "-",
                         _fmt(e["default_error"], 3), _fmt(e["band"], 3), _fmt(e["within"]), _fmt(e["uncertainty"], 3)])
    verdict = scene["classification"]
    if scene["sensitive"]:
        verdict += ": " + ", ".join(f"{q} +- {u:.3g}" for q, u in scene["sensitive"].items())
    text = (f"{scene['duration_s']:g} s simulated, plant time step {scene['time_step_s']:g} s; default rung "
            f"{scene['default_rung']}, reference rung {scene['reference_rung']}. **{verdict}**")
    notes = [f"- {q}: mesh sequence {e['mesh_gci']['note']}" for q, e in scene["quantities"].items() if e["mesh_gci"]["note"]]
    return [Section(f"{scene['scene']}", [Text(text)]),
            Section("Rungs", [rung_table], level=3),
            Section("Quantities per rung", [table(["quantity", *names], quantity_rows)], level=3),
            Section("Convergence (GCI: absolute, in the quantity's unit)",
                    [table(["quantity", "mesh p", "mesh Fs", "mesh GCI", "mesh sequence", "accuracy GCI", "accuracy",
                            "|default - reference|", "band", "within", "uncertainty"], gci_rows),
                     Text("\n".join(notes))], level=3)]


def summary_lines(study: dict) -> list[str]:
    """One line per scene: classification, reference, the walls per rung."""
    lines = []
    for s in study["scenes"]:
        walls = ", ".join(f"{n} {r['wall_s']:.2f} s" if r["wall_s"] is not None else f"{n} {r['status']}"
                          for n, r in s["rungs"].items())
        extra = "; ".join(f"{q} +- {u:.3g}" for q, u in s["sensitive"].items())
        lines.append(f"{s['scene']}: {s['classification']} (reference {s['reference_rung']})"
                     + (f" [{extra}]" if extra else "") + f"; wall: {walls}")
    return lines


def write_report(study: dict, out: str | Path) -> None:
    """truth.json and truth.md under `out`."""
    out = Path(out)
    write_atomic(out / "truth.json", json.dumps(study, indent=1, default=json_default))
    sections = [Section(None, [Text("How far each scene's default truth (Drake's discrete plant, polygon contact surfaces, "
                               "the scene's time step) lies from a converged answer, and what each rung of the "
                               "ladder costs. Method: docs/truth.md.")])]
    for scene in study["scenes"]:
        sections += scene_sections(scene)
    write_atomic(out / "truth.md", to_markdown("Truth ladder", sections))
