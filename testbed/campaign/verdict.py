"""A campaign's verdict from its sample records (testbed/campaign/sample.py): the agreement rate with the
truth and its 95 % Wilson score interval (scipy.stats.binomtest: well-kept, and Wilson's interval keeps
its coverage near 0 and 1 where the normal approximation does not), the final-error distribution on the
well-posed samples, the outcome table, the worst samples. The gate: the interval's lower end at least
REQUIRED_LOWER (with 32 samples all agreeing the lower end is 0.89; with 29 of 32, 0.76: fails). Every
sample agreeing but too few of them to reach it (fewer than 16) is UNDECIDED, not a pass.
"""

from __future__ import annotations

import numpy as np

REQUIRED_LOWER = 0.8  # [-] the agreement interval's lower end a PASS needs
WORST = 5  # worst samples listed


def wilson(k: int, n: int) -> tuple[float, float]:
    """The 95 % Wilson score interval of k successes in n trials ((nan, nan) for n = 0)."""
    if n == 0:
        return float("nan"), float("nan")
    from scipy.stats import binomtest

    ci = binomtest(k, n).proportion_ci(confidence_level=0.95, method="wilson")
    return float(ci.low), float(ci.high)


def summarise(records: list[dict]) -> dict:
    """The verdict's figures (module docstring)."""
    judged = [r for r in records if r["status"] == "ok"]
    k, n = sum(r["agree"] for r in judged), len(judged)
    low, high = wilson(k, n)
    posed = [r for r in judged if r["well_posed"]]
    errors = np.array([r["final_error_m"] for r in posed], dtype=float)
    table: dict = {}
    for r in judged:
        key = f"{r['classes']['truth']} -> {r['classes']['candidate']}"
        table[key] = table.get(key, 0) + 1
    worst = sorted(judged, key=lambda r: (r["agree"], -r["final_error_m"]))[:WORST]
    passed = n > 0 and low >= REQUIRED_LOWER and not any(r["status"] == "error" for r in records)
    # every judged sample agrees but there are too few of them to put the lower end at REQUIRED_LOWER
    undecided = not passed and n > 0 and k == n and not any(r["status"] == "error" for r in records)
    return {"samples": len(records), "judged": n, "refused": sum(r["status"] == "refused" for r in records),
            "errors": sum(r["status"] == "error" for r in records), "agree": int(k),
            "agreement": k / n if n else float("nan"), "interval_95": [low, high], "required_lower": REQUIRED_LOWER,
            "well_posed": len(posed), "final_error_median_m": float(np.median(errors)) if len(errors) else None,
            "final_error_p95_m": float(np.percentile(errors, 95)) if len(errors) else None,
            "outcomes": dict(sorted(table.items())), "worst": [r["index"] for r in worst],
            "needed": needed_samples(), "verdict": "PASS" if passed else "UNDECIDED" if undecided else "FAIL"}


def needed_samples(required: float = REQUIRED_LOWER) -> int:
    """The fewest samples that, all agreeing, put the interval's lower end at `required` (16 for 0.8)."""
    n = 1
    while wilson(n, n)[0] < required:
        n += 1
    return n
