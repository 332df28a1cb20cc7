"""A validation case and the interface of a case kind.

A case is a small JSON-able description (`Case`): a worker builds its own diagram from
it (pydrake objects do not pickle), runs it and returns a JSON-able result. A case kind
(one module in this package, registered with `@register`) says everything about its
cases: which cases each suite has, how one runs, which gates it judges and which
report sections it contributes (structured: testbed.document blocks).

A result record (what executors write to cases/<id>.json) is the case's fields plus
status ("ok" | "error"), result (the kind's dict, or {"error", "traceback"}) and
wall_s [s].
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar


@dataclasses.dataclass(frozen=True)
class Case:
    id: str  # unique and file-name safe
    kind: str  # the name of a registered CaseKind
    params: dict

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)


class CaseKind:
    """Base class of case kinds. Subclasses set `name` and override the hooks."""

    name: ClassVar[str] = ""
    order: ClassVar[int] = 100  # place of its cases in a suite (lower first)
    # Run in the main process after the pool, alone on the machine: for kinds that
    # start Meshcat (not in a worker) or measure time ratios that parallel cases disturb.
    main_process: ClassVar[bool] = False
    # Result fields that measure time (differ between two identical runs), besides the
    # names every kind shares (testbed/validation/report.py: is_timing_key).
    timing_keys: ClassVar[tuple[str, ...]] = ()

    def cases(self, suite: str) -> list[Case]:
        """This kind's cases in the named suite (default, full, smoke)."""
        return []

    def with_predictors(self, cases: list[Case], predictors: list[str]) -> list[Case]:
        """This kind's cases of a suite with more predictors to judge (`testbed validate
        --predictor`; learned_contact.sources strings, files as absolute paths): kinds
        that measure predictors add them, reported beside the shipped ones, not gated.
        Default: unchanged."""
        return cases

    def run(self, **params) -> dict:
        """Runs one case in this process and returns its JSON-able result."""
        raise NotImplementedError

    def gates(self, record: dict) -> list:
        """Gates judged from one result record with status "ok" (list of Gate)."""
        return []

    def sections(self, records: list[dict]) -> list:
        """Report sections (testbed.document.Section) from this kind's "ok" records."""
        return []

    def quick(self, records: list[dict]) -> str | None:
        """What of this kind ran in quick mode (a reduced study), as a phrase for the
        verdict line, or None."""
        return None
