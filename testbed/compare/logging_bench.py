"""What `contact_log` costs the closed loop: a bare learned run and a logged one, side by side.

    python -m testbed.compare.logging_bench [SCENE] [--duration S] [--repeats N]

Both runs are the scene with `learned_dynamics` (default config: the shadow truth on);
the bare one drops the recorders (contact_log, shadow_contact, learned_contact, meshcat),
the logged one keeps the scene's contact_log (adds one if it has none). Each is built
once and simulated `repeats` times alternately (bare, logged, bare, ...) in this process;
the wall time [s] is testbed.simulation's (the simulator's steps plus the effects'
collect). Prints each run's median and the median of the pairwise ratios logged / bare.
Not a test: machines are noisy, so no figure here is asserted anywhere.
"""

from __future__ import annotations

import argparse
import statistics


def scenes(scene: str, duration: float):
    """(bare, logged) Scenarios of `scene` with the learned closed loop, `duration` [s]."""
    from testbed.scenario import load_scenario

    base = [f"duration={duration!r}", "effects.learned_dynamics={}"]
    drop = [f"effects.{n}=null" for n in ("shadow_contact", "learned_contact", "meshcat")]
    bare = load_scenario(scene, overrides=base + drop + ["effects.contact_log=null"])
    logged_over = base + drop
    if load_scenario(scene).effects.contact_log is None:
        logged_over.append("effects.contact_log={}")
    return bare, load_scenario(scene, overrides=logged_over)


def measure(scene: str = "nine_mixed_stack", duration: float = 1.0, repeats: int = 3) -> dict:
    """{'bare_s': [...], 'logged_s': [...], 'ratio': [...], 'truth_rows': int, 'rows': int}:
    wall times [s] of each repeat and the pairwise ratios logged / bare."""
    import numpy as np

    from testbed.builder import build_scene
    from testbed.simulation import simulate

    bare, logged = scenes(scene, duration)
    out = {"bare_s": [], "logged_s": [], "ratio": []}
    for _ in range(repeats):
        b = simulate(build_scene(bare, scene)).summary["wall_time_s"]
        result = simulate(build_scene(logged, scene))
        w = result.summary["wall_time_s"]
        out["bare_s"].append(b)
        out["logged_s"].append(w)
        out["ratio"].append(w / b)
    table = result.tables.get("closed_loop", {})
    out["rows"] = int(len(table.get("a", ())))
    if "fn_truth" in table:
        out["truth_rows"] = int(np.count_nonzero(np.isfinite(table["fn_truth"])))
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene", nargs="?", default="nine_mixed_stack")
    parser.add_argument("--duration", type=float, default=1.0, help="simulated time [s] (default 1)")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args(argv)
    m = measure(args.scene, args.duration, args.repeats)
    print(f"{args.scene}, {args.duration:g} s simulated, {args.repeats} pairs (bare, logged) in one process")
    print(f"  bare learned run:  median {statistics.median(m['bare_s']):.3f} s  ({', '.join(f'{x:.3f}' for x in m['bare_s'])})")
    print(f"  with contact_log:  median {statistics.median(m['logged_s']):.3f} s  ({', '.join(f'{x:.3f}' for x in m['logged_s'])})")
    print(f"  logged / bare:     median {statistics.median(m['ratio']):.2f}x  ({', '.join(f'{x:.2f}' for x in m['ratio'])})")
    print(f"  closed_loop rows: {m['rows']}, with a truth answer: {m.get('truth_rows', 'n/a')}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
