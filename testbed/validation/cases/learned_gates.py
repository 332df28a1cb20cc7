"""Case kind `learned_gates`: the learned predictor's accuracy gates (learned_contact.gates).

No section of its own: its gates are listed with all the others."""

from __future__ import annotations

from learned_contact.gates import evaluate_gates
from testbed.validation.cases import Case, CaseKind, register
from testbed.validation.gates import Gate


@register
class LearnedGatesCase(CaseKind):
    name = "learned_gates"
    order = 50

    def cases(self, suite: str) -> list[Case]:
        return [Case("learned-gates", "learned_gates", {"seed": 0})] if suite in ("default", "full") else []

    def run(self, seed: int) -> dict:
        return evaluate_gates(seed=seed)

    def gates(self, record: dict) -> list[Gate]:
        return [Gate(f"learned: {g['name']}", g["passed"], g["value"], g["threshold"], g.get("unit", ""),
                     g.get("description", "")) for g in record["result"].get("gates", [])]
