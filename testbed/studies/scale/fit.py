"""The scale study's growth fits: the exponent b of the cost per step, us_per_step ~ a N^b.

The cost is the config's clock (settings.CLOCKS: CPU time per step by default, else wall time).
b is the least-squares slope of log(us per step) on log(N) over the completed timed windows
(past the settling transient) with N >= fit_from; its spread is the slope's standard error
from the fit's residuals (NaN with fewer than three points: two points fit exactly). One fit
per model and yard kind; pass_fits fits each pass of the grid on its own, so two passes give
two exponents whose difference says how repeatable the measurement is.
"""

from __future__ import annotations

import numpy as np


def fit_exponent(sizes, us_per_step) -> dict:
    """{'exponent' b, 'prefactor_us' a, 'stderr' (b's standard error), 'sizes'} of
    us_per_step ~ a N^b over the points (sizes (k,) containers, us_per_step (k,) [us]);
    NaN where fewer than two distinct sizes."""
    n, us = np.asarray(sizes, float), np.asarray(us_per_step, float)
    nan = float("nan")
    if len(set(n.tolist())) < 2:
        return {"exponent": nan, "prefactor_us": nan, "stderr": nan, "sizes": [int(x) for x in n]}
    x, y = np.log(n), np.log(us)
    b, log_a = np.polyfit(x, y, 1)
    stderr = nan
    if len(x) > 2:
        residual = y - (b * x + log_a)
        stderr = float(np.sqrt(residual @ residual / (len(x) - 2) / np.sum((x - x.mean()) ** 2)))
    return {"exponent": float(b), "prefactor_us": float(np.exp(log_a)), "stderr": stderr, "sizes": [int(v) for v in n]}


def growth_fits(rows: list[dict], models, fit_from: int, key: str = "us_per_step") -> dict:
    """model -> fit_exponent of rows' `key` [us per step] over the completed rows of `rows`
    (filter them by yard kind and pass first) with N >= fit_from, sizes ascending."""
    out = {}
    for m in models:
        pts = sorted((r["n"], r[key]) for r in rows if r["model"] == m and r["status"] == "ok" and r["n"] >= fit_from
                     and r.get(key) is not None and r[key] > 0)
        out[m] = fit_exponent([n for n, _ in pts], [u for _, u in pts])
    return out


def yard_fits(rows: list[dict], models, fit_from: int, yards, key: str = "us_per_step") -> dict:
    """yard kind -> model -> fit of `key` over every pass's rows of that yard."""
    return {y: growth_fits([r for r in rows if r.get("yard", "settled") == y], models, fit_from, key) for y in yards}


def pass_fits(rows: list[dict], models, fit_from: int, yards, passes: int, key: str = "us_per_step") -> dict:
    """str(pass) -> yard kind -> model -> fit of `key` over that pass's rows alone."""
    return {str(p): yard_fits([r for r in rows if r.get("pass", 1) == p], models, fit_from, yards, key)
            for p in range(1, passes + 1)}
