"""Case kind `learned_gates`: the learned predictor's accuracy gates (learned_contact.evaluation.gates).

The shipped predictor's gates are listed with all the others. Predictors added with
`testbed validate --predictor` get a case each (same held-out poses, same thresholds),
reported in a section of their own beside the shipped predictor's figures, not gated."""

from __future__ import annotations

from learned_contact import sources
from learned_contact.evaluation.gates import evaluate_gates
from testbed.document import Section, Text, table
from testbed.gates import Gate, KnownLimit
from testbed.validation.cases import Case, CaseKind, register


@register
class LearnedGatesCase(CaseKind):
    name = "learned_gates"
    order = 50

    def cases(self, suite: str) -> list[Case]:
        return [Case("learned-gates", "learned_gates", {"seed": 0})] if suite in ("default", "full") else []

    def with_predictors(self, cases: list[Case], predictors: list[str]) -> list[Case]:
        if not cases:
            return cases
        seed = cases[0].params["seed"]
        return cases + [Case(f"learned-gates-{sources.label(p)}", self.name, {"seed": seed, "predictor": p})
                        for p in predictors]

    def run(self, seed: int, predictor=None) -> dict:
        return {**evaluate_gates(seed=seed, predictor_path=predictor), "predictor": predictor}

    def gates(self, record: dict) -> list[Gate]:
        if record["result"].get("predictor") is not None:
            return []  # an added predictor: reported (sections), not gated
        return [_gate(g) for g in record["result"].get("gates", [])]

    def sections(self, records: list[dict]) -> list:
        shipped = [r for r in records if r["result"].get("predictor") is None]
        added = [r for r in records if r["result"].get("predictor") is not None]
        if not added:
            return []
        columns = ([("improved (shipped)", shipped[0]["result"])] if shipped else []) + \
            [(sources.label(r["result"]["predictor"]), r["result"]) for r in added]
        names = [g["name"] for g in columns[0][1]["gates"]]
        rows = []
        for name in names:
            row = [name]
            for _, result in columns:
                g = next(x for x in result["gates"] if x["name"] == name)
                row.append(f"{g['value']:.3g} {'pass' if g['passed'] else 'FAIL'}")
            threshold = next(x for x in columns[0][1]["gates"] if x["name"] == name)["threshold"]
            rows.append((*row, threshold))
        return [Section("Learned accuracy gates: added predictors (reported, not gated)", [
            Text("Each predictor given with --predictor on the same held-out poses as the shipped one, judged by the "
                 "same thresholds (learned_contact/evaluation/gates.py); only the shipped predictor's verdicts count toward the "
                 "run's verdict."),
            table(["gate", *[c[0] for c in columns], "threshold"], rows)], order=52)]


def _gate(g: dict) -> Gate:
    """A gate of learned_contact.evaluation.gates (a metrics dict) as the validation's Gate, its
    pinned known limit (when it is one) carried as the field."""
    known = g.get("known_limit")
    limit = KnownLimit(known["pinned"], tuple(known["band_factors"]), known["why"]) if known else None
    return Gate(f"learned: {g['name']}", g["passed"], g["value"], g["threshold"], g.get("unit", ""),
                g.get("description", ""), bound=g.get("bound"), known_limit=limit, uncertainty=g.get("truth_uncertainty"))
