"""The validation's use of the gates (testbed.gates): the gate every case has."""

from __future__ import annotations

from testbed.gates import KNOWN_LIMIT, Gate, format_value, is_known_limit, shown


def ran(record: dict) -> Gate:
    """The gate every case has: it finished without an exception (failed ones only)."""
    return Gate(f"{record['id']}: ran", False, record["result"].get("error"), None, "",
                "the case finished without an exception")


__all__ = ["KNOWN_LIMIT", "Gate", "format_value", "is_known_limit", "ran", "shown"]
