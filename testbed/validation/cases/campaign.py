"""Case kind `campaign`: a quick campaign over each knife-edge scene's family (testbed/families/), the
shipped predictor in the learned loop against the family's truth, judged by the campaign gates
(testbed/campaign/gates.py: the outcome agreement's 95 % Wilson lower end, the well-posed samples'
final error).

Why: on crane_edge_landing, stack_slide_off and ship_bay_open one trajectory from a balance point says
little (the truth's own end moves metres with a millimetre of start), so their final position and angle
are no longer gated on the one trajectory (testbed.gates.closed_loop.FAMILY_JUDGED) but by the rate at
which the candidate picks the truth's outcome over the family. Each case runs its samples in its worker,
one after the other (QUICK: few samples, short durations); the report shows each family's agreement,
interval and gates. Sections: one line near the verdict, and a table per family.
"""

from __future__ import annotations

import time
from pathlib import Path

from learned_contact import sources
from testbed.campaign.family import load_family
from testbed.campaign.gates import QUICK, campaign_gates, lower_bound, outcome_agreement
from testbed.campaign.sample import run_sample
from testbed.campaign.verdict import summarise
from testbed.document import Section, Text, table
from testbed.validation.cases import Case, CaseKind, register
from testbed.validation.gates import Gate

FAMILIES = Path(__file__).resolve().parents[2] / "families"  # the shipped families
KEPT = ("index", "values", "status", "classes", "final_error_m", "final_angle_deg", "truth_spread_m", "well_posed",
        "agree", "wall_s", "error", "refused")  # a sample's record fields the case keeps
SEED = 0


def campaign_cases(candidate: str = sources.DEFAULT) -> list[Case]:
    return [Case(f"campaign-{name}", "campaign", {"family": name, "samples": n, "duration": d, "candidate": candidate})
            for name, (n, d) in QUICK.items()]


def run_campaign(family: str, samples: int, duration: float, candidate: str = sources.DEFAULT, seed: int = SEED) -> dict:
    """A shipped family's campaign in this process: {"family", "candidate", "samples", "duration_s",
    "summary" (verdict.summarise), "records", "wall_s_per_sample"}."""
    path = FAMILIES / f"{family}.yaml"
    start = time.perf_counter()
    records = [run_sample({"family": str(path), "sample": s, "candidate": candidate, "duration": duration})
               for s in load_family(path).sample(samples, seed)]
    wall = time.perf_counter() - start
    return {"family": family, "candidate": candidate, "samples": samples, "duration_s": float(duration),
            "summary": summarise(records), "records": [{k: r[k] for k in KEPT if k in r} for r in records],
            "wall_s_per_sample": wall / max(samples, 1)}


@register
class CampaignCase(CaseKind):
    name = "campaign"
    order = 16
    timing_keys = ("wall_s_per_sample",)

    def cases(self, suite: str) -> list[Case]:
        return campaign_cases() if suite in ("default", "full") else []

    def run(self, family: str, samples: int, duration: float, candidate: str = sources.DEFAULT) -> dict:
        return run_campaign(family, samples, duration, candidate)

    def gates(self, record: dict) -> list[Gate]:
        r = record["result"]
        return campaign_gates(r["family"], r["summary"], f"{record['id']}: {sources.label(r['candidate'])}: ")

    def sections(self, records: list[dict]) -> list[Section]:
        if not records:
            return []
        parts = [_line(r["result"], self.gates(r)) for r in records]
        rows = [(r["result"]["family"], f"{k} / {n}", _interval(n, low, high), f"{lower_bound(r['result']['family']):g}",
                 f"{s['agree']} / {s['judged']} ({_interval(n, *s['interval_95'])})",
                 "PASS" if all(g.passed for g in self.gates(r)) else "FAIL", s["well_posed"],
                 _mm(s["final_error_p95_m"]), ", ".join(f"{key} {v}" for key, v in s["outcomes"].items()),
                 f"{r['result']['duration_s']:g}", f"{r['result']['wall_s_per_sample']:.3g}")
                for r in records for s in [r["result"]["summary"]] for k, n, low, high in [outcome_agreement(s)]]
        return [Section(None, [Text("Knife-edge scenes by family (quick campaigns, the shipped predictor): "
                                    + "; ".join(parts) + ".")], order=7),
                Section("Knife-edge scenes: campaign verdicts", [
                    Text("crane_edge_landing, stack_slide_off and ship_bay_open end where a balance point sends them; "
                         "their final position and angle are judged here, over a family of samples about that point "
                         "(testbed/families/), not on one trajectory. Per sample the truth, the truth from a start "
                         "1 mm away (well posed: it ends within 5 mm) and the learned loop; the candidate agrees when "
                         "its outcome class is the truth's. Gated: that agreement's 95 % Wilson interval's lower end at "
                         "least the family's bound; where samples are well posed, their final error's p95 within 2 cm "
                         "(the campaign's own agreement, the class and within 2 cm and 0.5 deg where well posed, is "
                         "shown beside). A quick campaign's few samples bound the rate loosely: "
                         "`testbed campaign <family>` runs the family's full count."),
                    table(["family", "outcome agrees / judged", "95 % interval", "lower end needed",
                           "and within 2 cm, 0.5 deg where well posed (interval)", "gates", "well posed",
                           "well-posed final error p95", "truth -> candidate", "simulated [s]", "wall per sample [s]"],
                          rows)], order=16)]


def _line(result: dict, gates: list[Gate]) -> str:
    k, n, low, high = outcome_agreement(result["summary"])
    verdict = "PASS" if gates and all(g.passed for g in gates) else "FAIL"
    failed = [g for g in gates[1:] if not g.passed]  # the error gate, where it fails
    return (f"{result['family']} {verdict}, the outcome agrees in {k} of {n}, 95 % interval {_interval(n, low, high)} "
            f"(lower end needed {lower_bound(result['family']):g})"
            + "".join(f", well-posed final error p95 {_mm(g.value)} (bound {_mm(g.threshold)})" for g in failed))


def _interval(n: int, low: float, high: float) -> str:
    return "n/a" if n == 0 else f"{low:.2f}-{high:.2f}"


def _mm(x) -> str:
    return "-" if x is None else f"{1e3 * x:.3g} mm"
