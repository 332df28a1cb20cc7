"""The bounds every untrusted model runs under (`ModelLimits`), process-wide: read from the
environment at import (so worker and vetting processes start with their parent's), changed
with `set_limits` (the command line's --model-load-timeout, --model-call-timeout,
--model-memory and --model-max-nodes), and named in one line when exceeded (`bound_text`,
`stopped_error`). What each bound covers: learned_contact/predictors/limits.py."""

from __future__ import annotations

import dataclasses
import json
import os

from learned_contact.errors import PredictorTimeoutError, WeightsError

GiB = 1 << 30


@dataclasses.dataclass(frozen=True)
class ModelLimits:
    """The bounds every untrusted model runs under (see the module docstring)."""

    load_timeout_s: float = 30.0  # [s] the shipped model's ONNX export loads and probes in ~1 s here
    call_timeout_s: float = 10.0  # [s] one call; the shipped model answers 1,000 poses in ~15 ms
    memory_bytes: int = 2 * GiB  # resident memory of the vetting child; model file + external data
    max_nodes: int = 20_000  # ONNX nodes with subgraphs; the shipped improved export has 2,368 (with the quadrature)


FLAGS = {"load_timeout_s": "--model-load-timeout", "call_timeout_s": "--model-call-timeout",
         "memory_bytes": "--model-memory", "max_nodes": "--model-max-nodes"}
# set_limits writes the bounds here as JSON so that worker processes (validate's process pool,
# bench and vetting children) start with them
ENVIRONMENT = "TESTBED_MODEL_LIMITS"


def _from_environment() -> ModelLimits:
    try:
        given = {k: v for k, v in json.loads(os.environ.get(ENVIRONMENT, "{}")).items() if k in FLAGS}
        if not all(isinstance(v, (int, float)) and 0 < v < float("inf") for v in given.values()):
            return ModelLimits()
        return dataclasses.replace(ModelLimits(), **given)
    except (ValueError, TypeError, AttributeError):
        return ModelLimits()


_limits = _from_environment()


def limits() -> ModelLimits:
    """The bounds in force (process-wide)."""
    return _limits


def set_limits(**changes) -> ModelLimits:
    """Changes some bounds (ModelLimits field names); returns the bounds now in force. Each
    value must be positive; raises WeightsError naming the flag otherwise."""
    global _limits
    for name, value in changes.items():
        if name not in FLAGS:
            raise WeightsError(f"unknown model limit {name!r}; expected one of {sorted(FLAGS)}")
        if not (isinstance(value, (int, float)) and value > 0 and value == value and value != float("inf")):
            raise WeightsError(f"{FLAGS[name]} {value!r}: expected a positive finite number")
    _limits = dataclasses.replace(_limits, **changes)
    os.environ[ENVIRONMENT] = json.dumps(dataclasses.asdict(_limits))
    return _limits


def bound_text(name: str) -> str:
    """'10 s (--model-call-timeout)' for one bound."""
    value = getattr(_limits, name)
    text = f"{value / GiB:.3g} GiB" if name == "memory_bytes" else f"{value:g} s" if name.endswith("_s") else f"{value:g}"
    return f"{text} ({FLAGS[name]})"


def stopped_error(source: str, what: str, bound: str, calls: int = 1) -> PredictorTimeoutError:
    """The one-line PredictorTimeoutError for a call (calls > 1: a round of that many) of `source`
    stopped by the bound `bound` (a ModelLimits field, [s])."""
    limit = bound_text(bound) if calls == 1 else f"{calls * getattr(_limits, bound):g} s ({calls} x {FLAGS[bound]})"
    return PredictorTimeoutError(f"{source}: {what} took longer than {limit} and was stopped; "
                                 "expected an answer within the bound")
