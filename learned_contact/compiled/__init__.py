"""The compiled inference path of the contact predictors: the Python face of the native core.

The core is C11 (native/src: the separating-axis test, the geometric estimate and features,
the exact face-on-face integral, the networks, the improved and paper predictors; public
API native/include/container_contact.h), built by `pip install` into the extension
learned_contact._native (setup.py) and called here (kernels.py) with the lowest per-call
overhead Python allows. The predictors in learned_contact.predictors call it when loaded with
`load_predictor(..., compiled=True)` (the default); the numpy reference path
(`compiled=False`) stays the tests' oracle (tests/learned/test_native_core.py: the two agree
to 1e-12 m).

Where the extension is missing (no C compiler at install time), NATIVE_AVAILABLE is False
and a predictor asked for the compiled path answers on the numpy reference path instead,
saying so once per process on stderr (`say_not_built`).
"""

from __future__ import annotations

import sys

from learned_contact.compiled.kernels import (
    ACTIVATION_CODES,
    KIND_CODES,
    STALE,
    STATUS_NAMES,
    _native,
    box_depth,
    constants,
    features,
    mlp_spec,
    native_answer,
    native_check,
    native_depth,
    native_depth_of,
    native_model,
    native_predict,
)

NATIVE_AVAILABLE = _native is not None
NOT_BUILT = (f"{STALE}: using the numpy reference path" if STALE else
             "native core not built: using the numpy reference path (install a C compiler and run pip install -e . again)")
_said = False


def say_not_built() -> None:
    """Prints NOT_BUILT on stderr, once per process."""
    global _said
    if not _said:
        _said = True
        print(NOT_BUILT, file=sys.stderr)


__all__ = ["ACTIVATION_CODES", "KIND_CODES", "NATIVE_AVAILABLE", "NOT_BUILT", "STATUS_NAMES", "box_depth", "constants", "features",
           "mlp_spec", "native_answer", "native_check", "native_depth", "native_depth_of", "native_model", "native_predict",
           "say_not_built"]
