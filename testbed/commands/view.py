"""`testbed view SCENE`: simulate a scene live in Meshcat, write its replay, serve until Ctrl-C."""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

from testbed import viz
from testbed.errors import TestbedError

NAME = "view"
HELP = "simulate a scene live in the Meshcat viewer, write its replay, serve until Ctrl-C"


def add_arguments(parser) -> None:
    parser.add_argument("scene", help="a scene YAML file or the name of a shipped scene")
    parser.add_argument("--port", type=int, default=viz.DEFAULT_PORT, help="TCP port (default 7000; 0 = any free port)")
    parser.add_argument("--host", default="localhost",
                        help="interface to listen on (default localhost; others warn: Meshcat has no authentication)")
    parser.add_argument("--rate", type=float, default=1.0,
                        help="target real-time rate (1 = real time, 0 = as fast as possible)")
    parser.add_argument("--duration", type=float, help="simulated time [s] (default: the scene's)")
    parser.add_argument("--out", help="run directory (default reports/runs/<scene>-view-<time>)")
    parser.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a scene field")


def run(args) -> int:
    if args.duration is not None and not args.duration > 0:
        raise TestbedError(f"--duration: expected a positive number of seconds, got {args.duration}")
    view(args.scene, port=args.port, host=args.host, rate=args.rate, overrides=args.set or [],
         duration=args.duration, out=args.out)
    return 0


def view(scene_path, *, port: int | None = viz.DEFAULT_PORT, host: str = "localhost", rate: float | None = 1.0,
         overrides=(), duration: float | None = None, out=None, serve: bool = True, stream=None):
    """`testbed view`: simulate a scene live in Meshcat, write its replay, keep serving.

    scene_path: scene file or shipped scene name; port: 0/None = a free one; host: the
    interface to listen on ("localhost" by default; others print an authentication
    warning); rate: target real-time rate (1 = real time, 0/None = as fast as possible);
    overrides: --set strings; duration [s]: default the scene's; out: the run directory
    (default reports/runs/<scene>-view-<time>); serve: after the run, keep serving until
    Ctrl-C. Returns (RunResult, replay path). Raises TestbedError on bad input / busy port.
    """
    from testbed.builder import build_scene
    from testbed.scenario import load_scenario, resolve_scene_path
    from testbed.simulation import simulate, write_run

    stream = stream or sys.stdout
    if rate is not None and not (rate >= 0 and math.isfinite(rate)):
        raise TestbedError(f"--rate: expected a non-negative real-time rate, got {rate}")
    if duration is not None and not duration > 0:
        raise TestbedError(f"--duration: expected a positive number of seconds, got {duration}")
    if port is not None and not 0 <= port <= 65535:
        raise TestbedError(f"--port: expected 0 to 65535, got {port}")
    path = resolve_scene_path(scene_path)
    settings = [f"effects.meshcat.host={json.dumps(host)}", f"effects.meshcat.port={port if port else 0}", "effects.meshcat.record=true"]
    scenario = load_scenario(path, overrides=list(overrides) + settings)
    scenario.simulator.target_realtime_rate = float(rate or 0.0)
    warning = viz.exposure_warning(host)
    if warning:
        print(warning, file=stream, flush=True)
    scene = build_scene(scenario, path)
    effect = scene.effects["meshcat"]
    print(f"Meshcat viewer: {effect.meshcat.web_url()}  (open it in a browser; Ctrl-C to stop)", file=stream, flush=True)
    if out is None:
        out = Path("reports") / "runs" / f"{scenario.name}-view-{time.strftime('%Y%m%d-%H%M%S')}"
    result = simulate(scene, duration=duration)
    write_run(result, out)
    replay = Path(out) / viz.REPLAY_NAME
    if not replay.exists():  # write_run may already have written it (Effect.files hook)
        viz.write_replay(effect.replay_html, replay)
    print(f"simulated {result.summary['duration_s']:g} s in {result.summary['wall_time_s']:.1f} s; "
          f"records: {out}\nreplay (opens from disk, no server needed): {replay} "
          f"({replay.stat().st_size / 1e6:.1f} MB); replay it live from the viewer's Animations controls",
          file=stream, flush=True)
    if serve:
        try:
            print(f"serving {effect.meshcat.web_url()} until Ctrl-C", file=stream, flush=True)
            while True:
                time.sleep(0.5)
        except KeyboardInterrupt:
            print("viewer stopped", file=stream, flush=True)
    return result, replay
