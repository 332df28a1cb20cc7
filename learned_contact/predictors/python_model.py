"""Loading a contact model written in Python: `module:attribute`.

The attribute is an object with a `predict` method, or a factory (a class or a function
called with no arguments) that returns one. The object answers

    predict(p_AB, R_AB, *, size_A, size_B) -> (point_A, normal_A)
                                            or (point_A, normal_A, depth)

on batches (p_AB (n, 3), R_AB (n, 3, 3), size_A and size_B (n, 3) full extents [m];
point_A (n, 3) [m] in A, normal_A (n, 3) unit from A into B, depth (n,) [m]), with any
framework behind it (numpy, torch, jax; arrays are converted with numpy.asarray). It
may also have `depth(p_AB, R_AB, *, size_A, size_B)` and `supported_sizes` ((k, 3) [m]);
what it lacks the bench fills in (the separating-axis depth; every container type the
testbed simulates). The module is imported as Python imports it, with the current
directory added at the end of sys.path (so `my_model.py` beside the scene works).
"""

from __future__ import annotations

import contextlib
import importlib
import os
import re
import sys

import numpy as np

from learned_contact.errors import PredictorOutputError, PredictorTimeoutError, WeightsError
from learned_contact.predictors import limits
from learned_contact.predictors.external import ExternalPredictor, default_sizes
from learned_contact.predictors.onnx_model import probe

SPEC = re.compile(r"^[A-Za-z_][\w.]*:[A-Za-z_][\w.]*$")


def is_python_spec(spec: str) -> bool:
    """Whether `spec` reads as module:attribute (module.path:name.path)."""
    return bool(SPEC.match(spec))


def _import(spec: str):
    module_name, _, attribute = spec.partition(":")
    here = os.getcwd()
    added = here not in sys.path
    if added:
        sys.path.append(here)
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise WeightsError(f"Python model {spec}: cannot import module {module_name!r} ({exc}); expected a module "
                           "importable from the current directory or PYTHONPATH") from None
    except BaseException as exc:  # noqa: BLE001 - the user's module failed while importing (SystemExit included)
        raise WeightsError(f"Python model {spec}: importing {module_name!r} raised {type(exc).__name__}: "
                           f"{str(exc)[:200]}") from None
    obj = module
    for part in attribute.split("."):
        if not hasattr(obj, part):
            raise WeightsError(f"Python model {spec}: module {module_name!r} has no attribute {attribute!r}; "
                               "expected a factory or an object with predict(p_AB, R_AB, *, size_A, size_B)")
        obj = getattr(obj, part)
    return obj


def _call(spec: str, method, p, R, sA, sB):
    """method(p, R, size_A=sA, size_B=sB) under the call bound; whatever it raises (SystemExit
    and KeyboardInterrupt included) becomes PredictorOutputError naming the model."""
    try:
        with limits.python_deadline(f"Python model {spec}"):
            return method(p, R, size_A=sA, size_B=sB)
    except PredictorOutputError:
        raise
    except BaseException as exc:  # noqa: BLE001 - the user's code may raise anything
        raise PredictorOutputError(f"Python model {spec}: {getattr(method, '__name__', 'predict')} raised "
                                   f"{type(exc).__name__} on a batch of {len(p)} poses: {str(exc)[:200]}") from None


@contextlib.contextmanager
def _own_round(spec: str, calls: int):
    """`calls` calls of the model's own predict in a row (ExternalPredictor.own_round) under calls x
    the call bound; whatever they raise becomes PredictorOutputError naming the model."""
    try:
        with limits.python_deadline(f"Python model {spec}", what=f"{calls} of its own calls in a row", calls=calls):
            yield
    except PredictorOutputError:
        raise
    except BaseException as exc:  # noqa: BLE001 - the user's code may raise anything
        raise PredictorOutputError(f"Python model {spec}: predict raised {type(exc).__name__} when called on its own: "
                                   f"{str(exc)[:200]}") from None


def load_python(spec: str) -> ExternalPredictor:
    """The model named by `module:attribute` behind the Predictor interface; anything the
    user's code raises while it is loaded and probed is one WeightsError line."""
    try:
        return _load_python(spec)
    except WeightsError:
        raise
    except BaseException as exc:  # noqa: BLE001 - a property or method of the user's object
        raise WeightsError(f"Python model {spec}: loading it raised {type(exc).__name__}: {str(exc)[:200]}") from None


def _load_python(spec: str) -> ExternalPredictor:
    target = _import(spec)
    if not callable(getattr(target, "predict", None)) or isinstance(target, type):
        if not callable(target):
            raise WeightsError(f"Python model {spec}: {type(target).__name__} is neither callable nor has predict(); "
                               "expected a factory or an object with predict(p_AB, R_AB, *, size_A, size_B)")
        try:
            with limits.python_deadline(f"Python model {spec}", "load_timeout_s", "its factory"):
                target = target()
        except PredictorTimeoutError as exc:
            raise WeightsError(str(exc)) from None
        except BaseException as exc:  # noqa: BLE001 - the user's factory failed (SystemExit, KeyboardInterrupt included)
            raise WeightsError(f"Python model {spec}: the factory raised {type(exc).__name__}: "
                               f"{str(exc)[:200]}") from None
    if not callable(getattr(target, "predict", None)):
        raise WeightsError(f"Python model {spec}: the factory returned {type(target).__name__} without predict(); "
                           "expected an object with predict(p_AB, R_AB, *, size_A, size_B)")
    sizes = getattr(target, "supported_sizes", None)
    if sizes is None:
        sizes = default_sizes()
    else:
        sizes = np.asarray(sizes, dtype=float)
        if sizes.ndim != 2 or sizes.shape[1] != 3 or len(sizes) == 0 or not np.all(np.isfinite(sizes)):
            raise WeightsError(f"Python model {spec}: supported_sizes has shape {sizes.shape}; "
                               "expected (k, 3) finite full extents [m]")

    def answer(p, R, sA, sB):
        out = _call(spec, target.predict, p, R, sA, sB)
        if not isinstance(out, (tuple, list)) or len(out) not in (2, 3):
            raise WeightsError(f"Python model {spec}: predict returned {type(out).__name__}; expected "
                               "(point_A, normal_A) or (point_A, normal_A, depth)")
        arrays = [np.asarray(v, dtype=float) for v in out]
        return arrays[0], arrays[1], (arrays[2] if len(arrays) == 3 else None)

    depth = getattr(target, "depth", None)
    depth_fn = (lambda p, R, sA, sB: _call(spec, depth, p, R, sA, sB)) if callable(depth) else None
    own_force = getattr(target, "force", None)

    def force(p, R, sA, sB):
        out = _call(spec, own_force, p, R, sA, sB)
        if not isinstance(out, (tuple, list)) or len(out) not in (2, 3):
            raise WeightsError(f"Python model {spec}: force returned {type(out).__name__}; expected "
                               "(force_n, stiffness) or (force_n, stiffness, area)")
        return out[0], out[1], (out[2] if len(out) == 3 else None)

    name = str(getattr(target, "name", None) or spec.rpartition(":")[2])
    predictor = ExternalPredictor(kind="python", name=name, answer=answer, supported_sizes=sizes, source=spec,
                                  depth_fn=depth_fn,
                                  own_call=lambda p, R, sA, sB: lambda: target.predict(p, R, size_A=sA, size_B=sB),
                                  own_round=lambda calls: _own_round(spec, calls),
                                  force_fn=force if callable(own_force) else None)
    probe(predictor)
    return predictor
