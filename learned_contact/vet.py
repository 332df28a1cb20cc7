"""The child process of learned_contact.predictors.limits.vet_in_child: `python -m learned_contact.vet
SPEC LIMITS_JSON` loads the model SPEC (an ONNX file or module:attribute) with its load-time
checks and probe, and prints nothing on success (exit 0) or one line `refused: <message as a JSON string>`
(exit 3). Anything the model's code raises or does (SystemExit included) is reported as
that line; a crash shows in the exit status, which the parent reads.
"""

from __future__ import annotations

import json
import os
import sys

from learned_contact.errors import WeightsError
from learned_contact.predictors import limits
from learned_contact.sources import load_unvetted


def main(argv: list[str], out) -> int:
    spec, payload = argv[0], json.loads(argv[1])
    limits.set_limits(**payload)
    if os.getcwd() not in sys.path:
        sys.path.append(os.getcwd())
    try:
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
