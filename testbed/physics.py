"""Shared physical constants and the small statistics every module uses.

One home for facts that several modules need, so they cannot drift apart.
"""

from __future__ import annotations

import numpy as np

GRAVITY = 9.81  # [m/s^2] magnitude of Drake's default MultibodyPlant gravity (-z in World)


def percentile_summary(values, percentiles=(50, 95, 99)) -> dict:
    """{'median'/'p95'/'p99'/'max': float} of a 1-D array (NaNs dropped); NaN when empty."""
    v = np.asarray(values, dtype=float).ravel()
    v = v[np.isfinite(v)]
    names = {50: "median"}
    out = {}
    for q in percentiles:
        out[names.get(q, f"p{q}")] = float(np.percentile(v, q)) if v.size else float("nan")
    out["max"] = float(v.max()) if v.size else float("nan")
    return out
