"""A campaign's summary (verdict.summarise) as gates (testbed.gates.Gate): what `testbed validate`
judges a knife-edge scene by, in place of a pinned known limit on one trajectory.

- outcome agreement: the 95 % Wilson interval's LOWER end of the rate at which the candidate's outcome
  class (seated, slid, tipped, fell, moving, diverged: testbed/campaign/sample.py) is the truth's (from
  the summary's truth -> candidate table), at least the family's bound (FAMILY_LOWER: the strictest its
  quick sample count can show, that count chosen from the measured cost per sample: below), with every
  sample run and at least one judged. A bound on the lower end, not on the rate: the gate passes only
  where the samples rule out, at 95 %, a rate below it; too few samples cannot pass it however they end.
- well-posed final error (where a sample is well posed: the truth's 1 mm perturbed twin ends within
  5 mm, so the truth's end is known to better than the bound): the p95 of the candidate's largest final
  distance from the truth over those samples within the closed-loop gates' 2 cm (FINAL_POSITION_TOL_M),
  as one trajectory's final position is gated. No well-posed sample: no such gate (the truth's end is not
  known better than its spread, the outcome alone judges), and the agreement gate says so.
The campaign's own verdict (the summary's agreement: the class and, where well posed, 2 cm and 0.5 deg
together) is in the agreement gate's description.

Neither gate has a pinned band: what it passes is its own bound.
"""

from __future__ import annotations

import math

from testbed.campaign.verdict import REQUIRED_LOWER, wilson
from testbed.gates import Gate, at_most
from testbed.gates.closed_loop import FINAL_POSITION_TOL_M

# family (its file's stem) -> (samples, simulated seconds per sample) of validate's quick campaign
# (testbed/validation/cases/campaign.py), and why so few: each sample is three runs (the truth, its
# perturbed twin, the candidate). Measured with the shipped predictor on the 2 shared cores (load ~5):
# edge_landing 42 s a sample (5 containers and a crane, 4 s: a tipping load is falling by then, a held
# one seated; at 2.5 s the shipped predictor's load had not yet tipped where the truth's had, at 4 s it
# has, and every point 5 cm off still holds it), slide_off 13 s (2 containers, 3.5 s: the slow tip off
# the end is over), rolling_bay 26 s (4 containers on the moving deck, 2.5 s: the roll's slide nearly
# over): 310 s of worker time for the three. The families' full 16 samples, which reach the campaign
# command's 0.8, cost 3.5-11 minutes a family.
QUICK = {"edge_landing": (3, 4.0), "slide_off": (6, 3.5), "rolling_bay": (4, 2.5)}


def strictest(n: int) -> float:
    """The bound a campaign of n samples is judged by: its interval's lower end with every sample agreeing
    (wilson(n, n)'s, floored to 0.01): the most n samples can show, so one disagreement fails."""
    return math.floor(100 * wilson(n, n)[0]) / 100


# family -> (the bound on the interval's lower end its validate campaign is judged by, why)
FAMILY_LOWER = {name: (strictest(n), f"{n} quick samples all agreeing put the lower end at {wilson(n, n)[0]:.2f}, "
                                     f"{n - 1} of {n} at {wilson(n - 1, n)[0]:.2f}: every sample must agree")
                for name, (n, _) in QUICK.items()}


def lower_bound(family: str) -> float:
    """The bound on the agreement interval's lower end `family` is judged by (REQUIRED_LOWER, the
    campaign command's, for a family without its own)."""
    return FAMILY_LOWER[family][0] if family in FAMILY_LOWER else REQUIRED_LOWER


def outcome_agreement(summary: dict) -> tuple[int, int, float, float]:
    """(samples whose candidate's outcome class is the truth's, judged samples, the 95 % Wilson interval's
    low and high ends), from a summary's truth -> candidate table."""
    n = summary["judged"]
    k = sum(count for key, count in summary["outcomes"].items() if len(set(key.split(" -> "))) == 1)
    return (k, n, *wilson(k, n))


def campaign_gates(family: str, summary: dict, prefix: str = "") -> list[Gate]:
    """The gates of one campaign's summary (module docstring), each named '<prefix><gate>'."""
    bound = lower_bound(family)
    k, n, low, high = outcome_agreement(summary)
    ok = n > 0 and summary["errors"] == 0 and not math.isnan(low) and low >= bound
    why = FAMILY_LOWER.get(family, (None, "the campaign command's own bound"))[1]
    posed = summary["well_posed"]
    both = summary["interval_95"]
    text = (f"the candidate's outcome class is the truth's in {k} of {n} judged samples of {family} "
            f"(95 % Wilson interval {_pct(low)}-{_pct(high)}; {summary['refused']} refused, {summary['errors']} failed "
            f"to run, which fails the gate); gated: the interval's lower end at least {bound:g} ({why}). "
            f"{posed} of {n} samples well posed" + ("" if posed else ": no final-error gate, the outcome alone judges")
            + f". The class and, where well posed, 2 cm and 0.5 deg together: {summary['agree']} of {n} (interval "
            f"{_pct(both[0])}-{_pct(both[1])}; at the campaign command's {summary['required_lower']:g}: "
            f"{summary['verdict']})")
    gates = [Gate(f"{prefix}outcome agreement (95 % lower end)", ok, low, bound, "", text)]
    if posed:
        p95 = summary["final_error_p95_m"]
        gates.append(Gate(f"{prefix}well-posed final error p95", at_most(p95, FINAL_POSITION_TOL_M), p95,
                          FINAL_POSITION_TOL_M, "m",
                          f"p95 over the {posed} well-posed samples of the candidate's largest final distance from the "
                          f"truth (median {_mm(summary['final_error_median_m'])}); the closed-loop gates' bound"))
    return gates


def _pct(x) -> str:
    return "n/a" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{100 * x:.0f} %"


def _mm(x) -> str:
    return "-" if x is None else f"{1e3 * x:.3g} mm"
