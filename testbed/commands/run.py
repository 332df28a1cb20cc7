"""`testbed run SCENE`: simulate one scene and write its records."""

from __future__ import annotations

from pathlib import Path

from testbed.commands import timestamp
from testbed.errors import TestbedError

NAME = "run"
HELP = "simulate one scene and write its records"


def add_arguments(parser) -> None:
    parser.add_argument("scene", help="a scene YAML file or the name of a shipped scene")
    parser.add_argument("--out", help="output directory (default reports/runs/<scene>-<time>)")
    parser.add_argument("--duration", type=float, help="simulated time [s] (default: the scene's)")
    parser.add_argument("--set", action="append", metavar="KEY=VALUE",
                        help="override a scene field, e.g. --set effects.contact.model=point --set containers[0].mass=25000")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.add_argument("--stall-timeout", type=float, default=120.0, metavar="SECONDS",
                        help="stop with exit status 1 if the simulated time does not advance for this much wall time "
                             "(default 120; testbed/watchdog.py)")


def run(args) -> int:
    from testbed.scenario import load_scenario, resolve_scene_path, source_label
    from testbed.simulation import run_scenario

    path = resolve_scene_path(args.scene)
    scenario = load_scenario(path, overrides=args.set or [])
    if args.duration is not None and not args.duration > 0:
        raise TestbedError(f"--duration: expected a positive number of seconds, got {args.duration}")
    if not args.stall_timeout > 0:
        raise TestbedError(f"--stall-timeout: expected a positive number of seconds, got {args.stall_timeout}")
    out = Path(args.out) if args.out else Path("reports") / "runs" / f"{scenario.name}-{timestamp()}"
    result = run_scenario(scenario, out_dir=out, duration=args.duration, progress=not args.quiet,
                          source=source_label(path, args.set),
                          stall_timeout=args.stall_timeout)
    print(format_summary(result.summary))
    print(f"  records: {out}")
    return 0


def format_summary(summary: dict) -> str:
    """A run summary (RunResult.summary) as the few lines `testbed run` prints."""
    lines = [
        f"scene {summary['scene']}: {summary['steps']} steps of {summary['time_step_s'] * 1e3:g} ms, "
        f"wall {summary['wall_time_s']:.2f} s, real-time factor {summary['real_time_factor']:.2f} "
        "(simulated time / wall time; > 1: faster than real time)",
        f"  contact model: {summary['contact_model']} ({summary['approximation']}); effects: {', '.join(summary['effects'])}",
    ]
    if "contact_rows" in summary:
        lines.append(
            f"  contacts: {summary['contact_rows']} rows, up to {summary['max_contacts_per_step']} per step; "
            f"max penetration {summary['max_penetration_m'] * 1e3:.3f} mm"
        )
    else:
        lines.append("  contacts: not recorded (declare the contact_log effect)")
    if "shadow_cop_distance_max_m" in summary:
        lines.append(
            f"  shadow ({summary['shadow_model']}): worst centre-of-pressure disagreement "
            f"{summary['shadow_cop_distance_max_m'] * 1e3:.1f} mm at step {summary['shadow_worst_step']}, "
            f"max normal angle {summary['shadow_normal_angle_max_deg']:.2f} deg"
        )
        if "point" in (summary["shadow_model"], summary.get("contact_model")):
            lines.append("    (point contact reports one point per pair, a corner of the contact face for face-on-face "
                         "contact, hydroelastic the centre of pressure: for boxes resting face on face they lie metres apart, a "
                         "difference in what each model reports, not an error)")
    if not summary.get("finite_state", True):
        lines.append("  WARNING: the final state is not finite (the simulation diverged)")
    return "\n".join(lines)
