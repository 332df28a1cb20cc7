"""Calls into the native core (learned_contact._native, C11: native/src): a predictor's
networks packed once into a native Model, then one C call per predict or depth.

Array arguments (all float64, C-contiguous): p (n, 3) [m] B's centre in A; R (n, 3, 3) B's
orientation in A; sA, sB (1, 3) or (n, 3) full extents [m] (one row broadcasts). The calls
return a status beside their outputs (STATUS_NAMES; container_contact.h's enum cc_status):
0 ok, 1 non-finite pose, 2/3 size_A/size_B not supported, 4/5 size_A/size_B not finite, 6
R_AB not a proper rotation (interface.ROTATION_TOLERANCE), 7 a bad argument; and the first
bad row (the predictors turn statuses 1-6 into the numpy reference path's errors).

The C core carries its own copies of the constants it shares with Python (the domain
bounds, tolerances, tilt bands, scales); `constants()` reads them back and
tests/learned/test_native_core.py holds each equal to its Python value.
"""

from __future__ import annotations

import importlib

import numpy as np

ABI_VERSION = 4  # CC_ABI_VERSION of the headers this binding's calls were written against

try:  # by name: `from learned_contact import _native` reads to import-linter as the package's __init__
    _native = importlib.import_module("learned_contact._native")
except ImportError:  # not built: learned_contact.compiled.NATIVE_AVAILABLE is False
    _native = None


def stale(module, expected: int = ABI_VERSION) -> str | None:
    """Why an extension module cannot be called into (its header's and its core's ABI versions are not
    `expected`: built from other sources, as a checkout pulled without `pip install -e .` again), or None."""
    if module is None:
        return None
    header, library = getattr(module, "ABI_VERSION", None), getattr(module, "LIBRARY_ABI_VERSION", None)
    if header == library == expected:
        return None
    return f"native core built for ABI {library if library is not None else header}, this code needs {expected}: " \
           "run pip install -e . again"


# The version check (MuJoCo's mj_version habit): a stale extension is not called into, and says so.
STALE = stale(_native)
if STALE is not None:
    _native = None

ACTIVATION_CODES = {"tanh": 0, "silu": 1, "relu": 2}  # enum cc_activation
KIND_CODES = {"improved": 1, "paper": 2}  # enum cc_kind
STATUS_NAMES = {0: "ok", 1: "non-finite pose", 2: "size_A not supported", 3: "size_B not supported",
                4: "size_A not finite", 5: "size_B not finite", 6: "R_AB not a rotation", 7: "bad argument"}


def mlp_spec(mlp) -> tuple:
    """(x_mean, x_std, (W_0, ...), (b_0, ...), activation code) of a NumpyMLP, as float64
    C-contiguous arrays (W_i (in, out)): what _native.Model takes for a network."""
    f = lambda a: np.ascontiguousarray(a, dtype=float)  # noqa: E731
    return (f(mlp.x_mean).reshape(-1), f(mlp.x_std).reshape(-1), tuple(f(W) for W in mlp.weights),
            tuple(f(b).reshape(-1) for b in mlp.biases), ACTIVATION_CODES[mlp.activation])


def native_model(kind: str, supported_sizes, mlp, expert=None, domain=None, *, size_range=None):
    """The native core's Model of a predictor: kind "improved" or "paper", supported_sizes
    (k, 3) full extents [m], the main network and (improved only) the resting expert with
    its gate's bounds (11 or 9 values; learned_contact.model.expert); size_range (2, 3) [m] or
    None: any box inside it answers too. The Model keeps the
    arrays it reads alive; build it once per predictor."""
    sizes = np.ascontiguousarray(supported_sizes, dtype=float).reshape(-1, 3)
    ranged = {} if size_range is None else {"size_range": np.ascontiguousarray(size_range, dtype=float).reshape(2, 3)}
    if expert is None:
        return _native.Model(KIND_CODES[kind], sizes, mlp_spec(mlp), **ranged)
    return _native.Model(KIND_CODES[kind], sizes, mlp_spec(mlp), mlp_spec(expert),
                         np.ascontiguousarray(domain, dtype=float).reshape(-1), **ranged)


def native_predict(model, p, R, sA, sB, with_depth: bool = True):
    """(point (n, 3) [m] in A, normal (n, 3) unit A->B, depth (n,) [m] or None unless
    with_depth, status, row): cc_predict on checked-shape arrays (module docstring)."""
    n = len(p)
    point, normal = np.empty((n, 3)), np.empty((n, 3))
    depth = np.empty(n) if with_depth else None
    status, row = _native.predict(model, p, R, sA, sB, point, normal, depth)
    return point, normal, depth, status, row


def native_answer(model, p_AB, R_AB, size_A, size_B, with_depth: bool):
    """The fast path of a predictor's predict: (status, row, point, normal, depth or None,
    how many poses lie outside DOMAIN_DEPTH (0 without depth)) straight from the caller's
    inputs where they are float64 C-contiguous numpy arrays of the interface's shapes
    (point, normal (3,) for a single pose, (n, 3) else); None otherwise (then convert and
    check the shapes in Python and call native_predict)."""
    return _native.answer(model, p_AB, R_AB, size_A, size_B, with_depth)


def native_depth_of(model, p_AB, R_AB, size_A, size_B):
    """The fast path of a predictor's depth: (status, row, depth (a float for a single pose,
    else (n,) [m])) or None (native_answer's conditions)."""
    return _native.depth_of(model, p_AB, R_AB, size_A, size_B)


def native_depth(model, p, R, sA, sB):
    """(depth (n,) [m] separating-axis penetration, status, row): cc_depth."""
    depth = np.empty(len(p))
    status, row = _native.depth(model, p, R, sA, sB, depth)
    return depth, status, row


def native_check(supported, p, R, sA, sB) -> int:
    """cc_predict's input checks (interface.check_numpy's, in its order: finite poses, proper
    rotations, finite and supported sizes) on shape-checked arrays, in C: the status (0 ok;
    module docstring). p (n, 3) [m], R (n, 3, 3), sA and sB (1, 3) or (n, 3) [m], supported
    (k, 3) [m]. A model the testbed did not ship checks its inputs so in a few microseconds;
    on a status other than 0 its caller runs check_numpy, which raises the reference's error."""
    f = np.ascontiguousarray
    return _native.check(f(supported, dtype=float), f(p, dtype=float), f(R, dtype=float), f(sA, dtype=float),
                         f(sB, dtype=float))[0]


def box_depth(p, R, sA, sB):
    """(n,) separating-axis penetration depth [m] of boxes of any size (no model, no size check:
    for a model the testbed did not ship, whose inputs learned_contact.interface has checked):
    the core's depth, as testbed.geometry.boxes.sat_normal's. p (n, 3) [m], R (n, 3, 3), sA and
    sB (1, 3) or (n, 3) full extents [m]."""
    f = np.ascontiguousarray
    p, R, sA, sB = f(p, dtype=float), f(R, dtype=float), f(sA, dtype=float), f(sB, dtype=float)
    depth = np.empty(len(p))
    _native.box_depth(p, R, sA, sB, depth)
    return depth


def features(p, R, sA, sB):
    """(x (n, N_FEATURES), point_est (n, 3) [m], normal_est (n, 3)) in the canonical frame:
    model.encodings.features of canonicalised poses, in C (no input checks; the part of the
    improved predictor without the networks and the quadrature, timed alone by the benchmark)."""
    n = len(p)
    x, point_est, normal_est = np.empty((n, _native.constants()["N_FEATURES"])), np.empty((n, 3)), np.empty((n, 3))
    _native.features(p, R, sA, sB, x, point_est, normal_est)
    return x, point_est, normal_est


def constants() -> dict:
    """{name: value} of the constants the C core holds (kernels' module docstring)."""
    return _native.constants()
