"""The child process of learned_contact.predictors.limits.vet_in_child: `python -m learned_contact.vet
SPEC LIMITS_JSON` loads the model SPEC (an ONNX file or module:attribute) with its load-time
checks and probe, and prints nothing on success (exit 0) or one line `refused: <message as a JSON string>`
(exit 3). Anything the model's code raises or does (SystemExit included) is reported as
that line; a crash shows in the exit status, which the parent reads.

The parent's load clock (--model-load-timeout) counts the model's time only: this process
first does the testbed's own start-up (its imports; onnxruntime for an ONNX file; the module
of a `module:attribute` model that is the testbed's own, e.g.
testbed.validation.sensitivity:bias_5cm), then tells the parent to start the clock
(limits.start_clock, on the pipe named by limits.CLOCK_ENVIRONMENT). The testbed's own work
while the model loads (learned_contact.sources loading and warming a shipped predictor the
model asks for) pauses that clock (limits.project_work).
"""

from __future__ import annotations

import contextlib
import importlib
import json
import os
import sys

from learned_contact.errors import WeightsError
from learned_contact.predictors import limits
from learned_contact.sources import load_unvetted, source_of

PROJECT_PACKAGES = ("learned_contact", "testbed")  # modules whose import time is the testbed's own


def own_start_up(spec: str) -> None:
    """Imports what loading `spec` needs that is not the model's code: onnx and onnxruntime for
    an ONNX file, the module of a `module:attribute` model inside PROJECT_PACKAGES. Failures
    are left to the load itself, which reports them."""
    key = source_of(spec).key
    names = ["onnx", "onnxruntime"] if key == "onnx" else []
    if key == "python" and spec.partition(":")[0].split(".")[0] in PROJECT_PACKAGES:
        names.append(spec.partition(":")[0])
    for name in names:
        with contextlib.suppress(Exception):
            importlib.import_module(name)


def main(argv: list[str], out) -> int:
    spec, payload = argv[0], json.loads(argv[1])
    limits.set_limits(**payload)
    fd = os.environ.pop(limits.CLOCK_ENVIRONMENT, None)
    if fd is not None and fd.isdigit():
        limits.report_clock_to(int(fd))
    if os.getcwd() not in sys.path:
        sys.path.append(os.getcwd())
    try:
        own_start_up(spec)
        limits.start_clock()
        load_unvetted(spec)
    except WeightsError as e:
        print("refused: " + json.dumps(str(e)), file=out, flush=True)
        return 3
    except BaseException as e:  # noqa: BLE001 - the model's code may raise anything, SystemExit included
        print("refused: " + json.dumps(f"model {spec}: loading it raised {type(e).__name__}: {str(e)[:200]}"), file=out,
              flush=True)
        return 3
    return 0


if __name__ == "__main__":
    answer = os.fdopen(os.dup(1), "w")  # our one line; the model's own output goes to stderr
    os.dup2(2, 1)
    sys.stdout = sys.stderr
    sys.exit(main(sys.argv[1:], answer))
