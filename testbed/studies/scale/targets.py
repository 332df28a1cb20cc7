"""The scale study's targets, read from a study record: how the cost per step grows with N for
the learned loops, and how fast they run at the largest yard.

- growth: the exponent of each learned loop's cost per step (fit.py) at most
  TARGET_EXPONENT[yard] in every pass (settled: nothing happens; crane: one load landing);
- repeatability: the exponents of two passes within TARGET_REPEAT of each other;
- speed at N = TARGET_N: the fastest learned loop (any host), in its slowest pass, at least
  TARGET_REAL_TIME[yard] times real time (the config's step over its cost per step on the
  config's clock: CPU or wall time).
"""

from __future__ import annotations

import math

from testbed.studies.scale.settings import CLOCKS, label, models

TARGET_EXPONENT = {"settled": 1.0, "crane": 1.1}  # [-] per-step growth, at most
TARGET_REPEAT = 0.1  # [-] the exponents of two passes differ by at most this
TARGET_N = 1000  # containers: the yard of the speed targets
TARGET_REAL_TIME = {"settled": 5.0, "crane": 1.0}  # [x real time] the fastest learned loop there, at least


def _learned(study: dict) -> list[str]:
    known = models()
    return [m for m in study["config"].get("models") or known if m in known and known[m].judged]


def targets(study: dict) -> list[dict]:
    """[{'target', 'measured', 'met': True | False | None (not measured)}] of the module doc's
    targets, for every learned model of the study and every yard kind it ran."""
    out = []
    yards = study["config"].get("yards", ("settled",))
    clock = study["config"].get("clock", "wall")
    passes = study.get("pass_fits", {})
    for y in yards:
        for m in _learned(study):
            fits = [passes[p][y][m] for p in sorted(passes) if m in passes[p].get(y, {})]
            done = [f for f in fits if math.isfinite(f["exponent"])]
            limit = TARGET_EXPONENT.get(y)
            text = ", ".join(f"{f['exponent']:.2f}" + (f" +- {f['stderr']:.2f}" if math.isfinite(f["stderr"]) else "")
                             + f" (N = {min(f['sizes'])}-{max(f['sizes'])})" for f in done)
            out.append({"target": f"{label(m)}, {y} yard: per-step growth exponent <= {limit:g} in every pass",
                        "measured": text or "not measured",
                        "met": all(f["exponent"] <= limit for f in done) if done else None})
            if len(done) >= 2:
                spread = max(f["exponent"] for f in done) - min(f["exponent"] for f in done)
                out.append({"target": f"{label(m)}, {y} yard: the passes' exponents within {TARGET_REPEAT:g}",
                            "measured": f"{spread:.2f} apart", "met": spread <= TARGET_REPEAT})
        at = [r for r in study["rows"] if r["n"] == TARGET_N and r.get("yard", "settled") == y and r["status"] == "ok"
              and r["model"] in _learned(study)]
        rtf = CLOCKS[clock][1]
        at = [r for r in at if r.get(rtf) is not None and math.isfinite(r[rtf])]
        worst = {}  # model -> its slowest pass (a target met in one pass only is not met)
        for r in at:
            if r["model"] not in worst or r[rtf] < worst[r["model"]][rtf]:
                worst[r["model"]] = r
        best = max(worst.values(), key=lambda r: r[rtf], default=None)
        goal = TARGET_REAL_TIME[y]
        out.append({"target": f"learned loop (any host), {y} yard of {TARGET_N}: >= {goal:g}x real time ({clock} time)",
                    "measured": f"{best[rtf]:.2f}x ({label(best['model'])}, its slowest pass)" if best else "not measured",
                    "met": best[rtf] >= goal if best else None})
    return out
