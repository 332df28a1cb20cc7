"""Gates: typed pass/fail verdicts with their threshold and why, and pinned known limits.

A gate judges one measured figure against a bound. A *pinned known limit* is a gate whose
bound the figure does not meet (a target out of reach, stated with its measured figure):
it is judged instead against a band around the figure pinned when it was measured, so that
the figure getting worse (or much better: re-pin it) still fails. `pinned` is the one
implementation of that band; a known limit carries it as the `known_limit` field (and its
name ends with KNOWN_LIMIT, for readers of metrics.json).

Every gate kind lives here or beside it: testbed.gates.closed_loop (the learned model in the
loop), the scene case's in-scene gate and learned_contact.evaluation.gates (accuracy on held-out poses)
build on these.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Optional

KNOWN_LIMIT = "(known limit)"  # the suffix of a pinned known limit's name


@dataclasses.dataclass(frozen=True)
class KnownLimit:
    """A target not met, pinned: `pinned` is the figure measured when it was pinned (in the
    gate's unit), `factors` (low, high) the band around it as multiples of `pinned`, `why` the
    reason the target is out of reach."""

    pinned: float
    factors: tuple[float, float]
    why: str

    @property
    def band(self) -> list[float]:
        """[low, high] in the gate's unit."""
        return [self.factors[0] * self.pinned, self.factors[1] * self.pinned]


@dataclasses.dataclass(frozen=True)
class Gate:
    """One verdict. value and threshold are JSON-able (a number, a [low, high] band, a bool or
    an error message); unit names their unit ("m", "x weight", ""). A pinned known limit has
    `known_limit` set, `threshold` its band and `bound` the gate's own bound it does not meet.
    `uncertainty`, where stated, is the reference's own uncertainty on this figure (in the
    gate's unit): no bound may lie below it (tests/project/test_gate_uncertainty.py)."""

    name: str
    passed: bool
    value: Any
    threshold: Any
    unit: str
    description: str
    bound: Any = None
    known_limit: Optional[KnownLimit] = None
    uncertainty: Optional[float] = None

    def to_dict(self) -> dict:
        """The gate as metrics.json holds it (testbed/validation/report_schema.json)."""
        out = {"name": self.name, "passed": bool(self.passed), "value": self.value, "threshold": self.threshold,
               "unit": self.unit, "description": self.description}
        if self.bound is not None:
            out["bound"] = self.bound
        if self.uncertainty is not None:
            out["truth_uncertainty"] = float(self.uncertainty)
        if self.known_limit is not None:
            out["known_limit"] = {"pinned": self.known_limit.pinned, "band_factors": list(self.known_limit.factors),
                                  "why": self.known_limit.why}
        return out


def at_most(value, limit) -> bool:
    """value <= limit, False for NaN or None (a figure that could not be measured fails)."""
    return value is not None and not (isinstance(value, float) and math.isnan(value)) and value <= limit


def pinned(name: str, value, bound, unit: str, description: str, limit: KnownLimit) -> Gate:
    """The gate `name` as a pinned known limit: passes while `value` lies in the limit's band
    (NaN or None fails), names itself '<name> (known limit)' and says both figures."""
    band = limit.band
    ok = value is not None and not (isinstance(value, float) and math.isnan(value)) and band[0] <= value <= band[1]
    return Gate(f"{name} {KNOWN_LIMIT}", ok, value, band, unit,
                f"{description}; known limit: the bound {bound} {unit} is not met, pinned at {limit.pinned:.4g} {unit}: "
                f"{limit.why}. Fails if the figure leaves the band.", bound=bound, known_limit=limit)


def is_known_limit(gate: dict) -> bool:
    """Whether a gate (as metrics.json holds it) is a pinned known limit."""
    return "known_limit" in gate or str(gate.get("name", "")).endswith(KNOWN_LIMIT)


def format_value(value, unit: str = "") -> str:
    """A gate's value or threshold as text: metres as mm, NaN as n/a, lists in brackets
    (each element in the unit); other units are not written (see `shown`)."""
    if isinstance(value, bool) or value is None:
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "n/a"
        if unit == "m":
            return f"{value * 1e3:.4g} mm"
        return f"{value:.4g}"
    if isinstance(value, list):
        return "[" + ", ".join(format_value(v, unit) for v in value) + "]"
    return str(value)


def shown(value, unit: str) -> str:
    """A gate's value or threshold with its unit, in the report's units: lengths in mm,
    drift in mm/min, angles in deg ('0.224 m' -> '224.1 mm', '1e-5 m/min' -> '0.01 mm/min')."""
    if unit == "m/min" and isinstance(value, (float, int)) and not isinstance(value, bool):
        return f"{value * 1e3:.4g} mm/min"
    if unit == "m/min" and isinstance(value, list):
        return "[" + ", ".join(shown(v, unit) for v in value) + "]"
    text = format_value(value, unit)
    return text if unit in ("", "m") or text in ("n/a", "None") or isinstance(value, bool) else f"{text} {unit}"


__all__ = ["KNOWN_LIMIT", "Gate", "KnownLimit", "at_most", "format_value", "is_known_limit", "pinned", "shown"]
