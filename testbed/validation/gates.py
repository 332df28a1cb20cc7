"""Gates: typed pass/fail verdicts with their threshold and why, judged from case results."""

from __future__ import annotations

import dataclasses
import math
from typing import Any


@dataclasses.dataclass(frozen=True)
class Gate:
    """One verdict. value and threshold are JSON-able (a number, a [low, high] band,
    a bool or an error message); unit names their unit ("m", "x weight", "")."""

    name: str
    passed: bool
    value: Any
    threshold: Any
    unit: str
    description: str

    def to_dict(self) -> dict:
        """The gate as metrics.json holds it (testbed/validation/report_schema.json)."""
        return {"name": self.name, "passed": bool(self.passed), "value": self.value, "threshold": self.threshold,
                "unit": self.unit, "description": self.description}


def ran(record: dict) -> Gate:
    """The gate every case has: it finished without an exception (failed ones only)."""
    return Gate(f"{record['id']}: ran", False, record["result"].get("error"), None, "",
                "the case finished without an exception")


def format_value(value, unit: str = "") -> str:
    """A gate's value or threshold as text: metres as mm, NaN as n/a, lists in brackets."""
    if isinstance(value, bool) or value is None:
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "n/a"
        if unit == "m":
            return f"{value * 1e3:.2f} mm"
        return f"{value:.4g}"
    if isinstance(value, list):
        return "[" + ", ".join(format_value(v) for v in value) + "]"
    return str(value)
