"""Accuracy per size class: the shipped predictor on container sizes it was not fitted on.

The improved predictor's network was fitted on 20 and 40 ft boxes (1CC, 1AA, 1AAA; training/config.py);
it answers every ISO 668 series 1 type and any box inside ANSWERED_SIZE_RANGE
(learned_contact/predictors/improved.py). This module measures what that costs in accuracy, class by
class, on held-out poses labelled by Drake for those sizes (the gates' held-out sets,
gates.held_out, over the class's types: ordered pairs drawn uniformly among them, so a class of two
types also holds some pairs of one type with itself):

- the point and normal gates of gates.THRESHOLDS, judged at their own bounds for ISO types (what
  20 and 40 ft pairs are held to) and at twice them for generic boxes, on the gates' own seed and
  pose count (seed 0, 400 proposals per set); where a class misses a bound it is pinned in
  KNOWN_LIMITS with its figure, and the table and the test say so;
- the force the closed loop applies (testbed/bench/force.py: the exact field contact) against Drake's
  static hydroelastic force on the same poses.

`python -m testbed.bench.size_classes [--n N] [--seed S]` prints the table (Markdown).
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np

from learned_contact.evaluation.gates import N_HELD_OUT, THRESHOLDS, gate_figures, held_out, limit_unit
from learned_contact.predictors.improved import ANSWERED_SIZE_RANGE
from learned_contact.sources import load_predictor
from testbed.bench.force import force_section
from testbed.bodies.containers import FITTED_TYPES, SERIES_1_WIDTH, generic_code
from testbed.gates import KnownLimit, pinned


@dataclasses.dataclass(frozen=True)
class SizeClass:
    """name; types: the container codes whose pairs are drawn; factor: the gates' bounds times this."""

    name: str
    types: tuple[str, ...]
    factor: float = 1.0


def generic_types(n: int = 8, seed: int = 3, size_range=None) -> tuple[str, ...]:
    """n generic box codes with full extents drawn uniformly in size_range ((2, 3) [m]; default the
    shipped predictor's ANSWERED_SIZE_RANGE), seeded."""
    lo, hi = np.asarray(ANSWERED_SIZE_RANGE if size_range is None else size_range, dtype=float)
    sizes = np.random.default_rng(seed).uniform(lo, hi, size=(n, 3))
    return tuple(generic_code(s) for s in sizes)


CLASSES = (
    SizeClass("20 / 40 ft (fitted)", FITTED_TYPES),
    SizeClass("45 ft high cube on 45 ft high cube", ("1EEE",)),
    SizeClass("45 ft high cube with 40 ft", ("1EEE", "1AA")),
    SizeClass("45 ft with 40 ft high cube", ("1EE", "1AAA")),
    SizeClass("30 ft (1BBB, 1BB, 1B)", ("1BBB", "1BB", "1B")),
    SizeClass("10 ft with 20 ft", ("1D", "1CC")),
    SizeClass("8 ft high (1A, 1C)", ("1A", "1C")),
    SizeClass("half heights (1AX, 1BX, 1CX, 1DX)", ("1AX", "1BX", "1CX", "1DX")),
    SizeClass("half heights with full heights", ("1CX", "1CC", "1AX", "1AAA")),  # fields of unequal depth
    SizeClass("generic boxes in range (8 sizes)", (), 2.0),  # types drawn by generic_types()
)
SETS = ("stacking", "general", "resting", "resting_wider")  # the pose sets judged per class
# On general poses (corners and edges: the learned pipeline's) the network's correction is a tie with its
# own geometric estimate on sizes outside the lengths and heights it was fitted on: the "vs prior" gates
# ask for <= 1.0, and the fitted sizes themselves measure 1.01-1.07 on some seeds (gates.THRESHOLDS).
# Measured on seed 0 (400 proposals): class -> gate -> KnownLimit; seeds 1 and 2 in the comment.
_TIE = ("on general poses the network's correction is only a tie with its geometric estimate for sizes "
        "outside the fitted lengths (6.058-12.192 m) and heights (2.591-2.896 m); the fitted sizes' own "
        "figure is 0.95 here and 1.01-1.07 on other seeds")
KNOWN_LIMITS = {
    "10 ft with 20 ft": {"general point error p95 vs prior": KnownLimit(1.068, (0.8, 1.25), _TIE)},  # 0.98, 0.96
    "8 ft high (1A, 1C)": {"general point error p95 vs prior": KnownLimit(1.060, (0.8, 1.25), _TIE)},  # 0.72, 1.04
    "half heights with full heights": {  # seeds 1, 2: 1.80 / 1.64 mm and 0.92 / 0.89
        "general point error median": KnownLimit(0.00204, (0.8, 1.25), "2 % over the 2 mm bound on seed 0 (1.64-1.80 mm "
                                                 "on seeds 1 and 2): " + _TIE),
        "general point error p95 vs prior": KnownLimit(1.02, (0.8, 1.25), _TIE)},
}
FORCE_SETS = ("stacking", "general", "resting")


def class_types(size_class: SizeClass) -> tuple[str, ...]:
    return size_class.types or generic_types()


def _gate(size_class: SizeClass, name: str, value: float, limit: float, unit: str, pins: dict) -> dict:
    bound = limit * size_class.factor
    if name in pins:
        gate = pinned(name, value, bound, limit_unit(name), f"{name} ({size_class.name})", pins[name])
        return {**gate.to_dict(), "passed": bool(gate.passed), "bound": bound, "pinned": True}
    return {"name": name, "value": value, "bound": bound, "unit": unit, "passed": bool(value <= bound), "pinned": False}


def measure(size_class: SizeClass, *, n: int = N_HELD_OUT, seed: int = 0, predictor=None, workers: int = 2,
            pins: dict | None = None) -> dict:
    """{"class", "types", "n", "seed", "gates": [{name, value, bound, passed, pinned}], "force": {set: figures}}
    for one class on held-out poses (gates.held_out over its types, seed `seed`, n proposals per set);
    pins: {gate: KnownLimit} (default: the class's KNOWN_LIMITS where n and seed are the gates' own)."""
    predictor = predictor or load_predictor("improved")
    types = class_types(size_class)
    if pins is None:
        pins = KNOWN_LIMITS.get(size_class.name, {}) if (n, seed) == (N_HELD_OUT, 0) else {}
    data = {k: v for k, v in held_out(seed, n, types=types, workers=workers).items() if k in SETS}
    figures = gate_figures(predictor, data)
    gates = [_gate(size_class, name, figures[name], limit, unit, pins)
             for name, (limit, unit) in THRESHOLDS.items() if name.split(" ")[0] in data and name in figures]
    force = force_section({k: data[k] for k in FORCE_SETS})["sets"]
    return {"class": size_class.name, "types": list(types), "factor": size_class.factor, "n": n, "seed": seed,
            "gates": gates, "force": {k: v["exact"] for k, v in force.items()},
            "width_m": SERIES_1_WIDTH}


def _cell(gates: list, name: str) -> str:
    g = next((g for g in gates if g["name"].startswith(name)), None)
    if g is None:
        return "-"
    value = g["value"] * (1e3 if g["unit"] == "m" else 1.0)
    mark = " **FAIL**" if not g["passed"] else (" (pinned)" if g["pinned"] else "")
    return f"{value:.3g}{mark}"


def markdown(rows: list[dict]) -> str:
    """The table: one row per class, point figures [mm], normal [deg], force relative error p95."""
    cols = ("stacking point error median", "stacking point error p95", "stacking normal error p95",
            "general point error median", "general point error p95", "general point error p95 vs prior",
            "resting point error p95", "resting_wider point error p95")
    head = ("| class | gates passed | " + " | ".join(c.replace(" error", "").replace("point", "pt")
                                                     for c in cols) + " | force rel. p95 |")
    lines = [head, "|" + "---|" * (len(cols) + 3)]
    for r in rows:
        passed = sum(g["passed"] and not g["pinned"] for g in r["gates"])
        held = sum(g["passed"] and g["pinned"] for g in r["gates"])
        bound = "" if r["factor"] == 1 else f" (at {r['factor']:g}x)"
        pins = f", {held} pinned" if held else ""
        force = max(v["force_rel_p95"] for v in r["force"].values())
        lines.append(f"| {r['class']} | {passed}/{len(r['gates'])}{bound}{pins} | "
                     + " | ".join(_cell(r["gates"], c) for c in cols) + f" | {force:.1e} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=N_HELD_OUT, help=f"proposals per pose set and class (default {N_HELD_OUT})")
    parser.add_argument("--seed", type=int, default=0, help="held-out seed (default 0, the gates' own)")
    args = parser.parse_args(argv)
    rows = [measure(c, n=args.n, seed=args.seed) for c in CLASSES]
    print(markdown(rows))
    return 0 if all(g["passed"] and not g["pinned"] for r in rows for g in r["gates"]) else 1


if __name__ == "__main__":
    raise SystemExit(main())
