"""Gates: typed pass/fail verdicts with their threshold and why, judged from case results."""

from __future__ import annotations

import dataclasses
import math
from typing import Any


@dataclasses.dataclass(frozen=True)
class Gate:
    """One verdict. value and threshold are JSON-able (a number, a [low, high] band,
    a bool or an error message); unit names their unit ("m", "x weight", ""). A pinned known
    limit (its name ends with KNOWN_LIMIT) is judged against a band around its pinned figure
    (threshold) and carries `bound`, the gate's own bound that the figure does not meet."""

    name: str
    passed: bool
    value: Any
    threshold: Any
    unit: str
    description: str
    bound: Any = None

    def to_dict(self) -> dict:
        """The gate as metrics.json holds it (testbed/validation/report_schema.json)."""
        out = {"name": self.name, "passed": bool(self.passed), "value": self.value, "threshold": self.threshold,
               "unit": self.unit, "description": self.description}
        if self.bound is not None:
            out["bound"] = self.bound
        return out


KNOWN_LIMIT = "(known limit)"  # the suffix of a pinned known limit's name (here and in learned_contact.gates)


def is_known_limit(gate: dict) -> bool:
    """Whether a gate (as metrics.json holds it) is a pinned known limit: it passes only
    while its figure stays in the band around the pinned one, outside its own bound."""
    return gate["name"].endswith(KNOWN_LIMIT)


def ran(record: dict) -> Gate:
    """The gate every case has: it finished without an exception (failed ones only)."""
    return Gate(f"{record['id']}: ran", False, record["result"].get("error"), None, "",
                "the case finished without an exception")


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
