"""What `contact_log` costs the closed loop: a bare learned run and a logged one, side by side.

    python -m testbed.compare.logging_bench [SCENE] [--duration S] [--repeats N]

Both runs are the scene with `learned_dynamics` (default config: the shadow truth on);
the bare one drops the recorders (contact_log, shadow_contact, learned_contact, meshcat),
the logged one keeps the scene's contact_log (adds one if it has none); a third, the
logged run with `shadow_truth: false`, separates the logger's own cost from the truth's.
Each is built afresh and simulated `repeats` times in turn (bare, logged, logged without
truth, bare, ...) in this process, after one short untimed warm-up run; the wall time
[s] is that of the whole testbed.simulation.simulate call (the simulator's steps, the
effects' collect and summaries), perf_counter. Prints each run's median and the median of the ratios to the
bare run of the same repeat. Not a test: machines are noisy, so no figure here is asserted.
"""

from __future__ import annotations

import argparse
import statistics

from testbed.builder import build_scene
from testbed.scenario import load_scenario
from testbed.simulation import simulate


def scenes(scene: str, duration: float):
    """(bare, logged) Scenarios of `scene` with the learned closed loop, `duration` [s]."""

    base = [f"duration={duration!r}", "effects.learned_dynamics={}"]
    drop = [f"effects.{n}=null" for n in ("shadow_contact", "learned_contact", "meshcat")]
    bare = load_scenario(scene, overrides=base + drop + ["effects.contact_log=null"])
    logged_over = base + drop
    if load_scenario(scene).effects.contact_log is None:
        logged_over.append("effects.contact_log={}")
    return bare, load_scenario(scene, overrides=logged_over)


def measure(scene: str = "nine_mixed_stack", duration: float = 1.0, repeats: int = 3,
            truth_every_steps: int | None = None) -> dict:
    """{'bare_s', 'logged_s', 'no_truth_s': [...] wall times [s] per repeat, 'ratio',
    'no_truth_ratio': [...] each over the same repeat's bare run, 'rows', 'truth_rows':
    the logged run's closed_loop rows and those with a truth answer}.
    truth_every_steps: the shadow truth's period (None: the effect's default)."""
    import dataclasses
    import time


    bare, logged = scenes(scene, duration)
    if truth_every_steps is not None:
        logged.effects.learned_dynamics = dataclasses.replace(logged.effects.learned_dynamics,
                                                              truth_every_steps=truth_every_steps)
    no_truth = copy_without_truth(logged)
    out = {"bare_s": [], "logged_s": [], "no_truth_s": []}
    # warm-up, not timed: the first run in a process imports what the pair plants and the
    # kernels need (~0.2 s once), which no later run pays
    simulate(build_scene(logged, scene), duration=min(duration, 0.05))
    for _ in range(repeats):
        for key, scenario in (("bare_s", bare), ("logged_s", logged), ("no_truth_s", no_truth)):
            built = build_scene(scenario, scene)
            start = time.perf_counter()
            result = simulate(built)
            out[key].append(time.perf_counter() - start)
            if key == "logged_s":
                table = result.tables.get("closed_loop", {})
    out["ratio"] = [w / b for w, b in zip(out["logged_s"], out["bare_s"])]
    out["no_truth_ratio"] = [w / b for w, b in zip(out["no_truth_s"], out["bare_s"])]
    out["rows"] = len(table.get("a", ()))
    # (a version without has_truth computed the truth on every row)
    out["truth_rows"] = int(table["has_truth"].sum()) if "has_truth" in table else len(table.get("fn_truth", ()))
    out["truth_every_steps"] = getattr(logged.effects.learned_dynamics, "truth_every_steps", 1)
    return out


def copy_without_truth(scenario):
    import copy
    import dataclasses

    out = copy.deepcopy(scenario)
    out.effects.learned_dynamics = dataclasses.replace(out.effects.learned_dynamics, shadow_truth=False)
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene", nargs="?", default="nine_mixed_stack")
    parser.add_argument("--duration", type=float, default=1.0, help="simulated time [s] (default 1)")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--truth-every-steps", type=int, default=None,
                        help="the shadow truth's period in steps (default: the effect's)")
    args = parser.parse_args(argv)
    m = measure(args.scene, args.duration, args.repeats, args.truth_every_steps)
    med = statistics.median

    def line(label, key):
        return f"  {label:<34} median {med(m[key]):.3f} s  ({', '.join(f'{x:.3f}' for x in m[key])})"

    print(f"{args.scene}, {args.duration:g} s simulated, {args.repeats} repeats in one process")
    print(line("bare learned run:", "bare_s"))
    print(line(f"contact_log, truth every {m['truth_every_steps']} steps:", "logged_s"))
    print(line("contact_log, no shadow truth:", "no_truth_s"))
    print(f"  logged / bare: median {med(m['ratio']):.2f}x ({', '.join(f'{x:.2f}' for x in m['ratio'])}); "
          f"without the truth {med(m['no_truth_ratio']):.2f}x ({', '.join(f'{x:.2f}' for x in m['no_truth_ratio'])})")
    print(f"  closed_loop rows: {m['rows']}, with a truth answer: {m['truth_rows']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
