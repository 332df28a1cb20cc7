"""Train/test split of tosses that keeps duplicated tosses on the same side.

Some tosses of the data set are recorded twice with the horizontal frame rotated: their
heights z(t) are identical. A duplicate on both sides of a split would let the fit see
test data, so duplicates are grouped first and groups are assigned whole.
"""

from __future__ import annotations

import numpy as np

from testbed.calibration.data import Toss
from testbed.errors import TestbedError

DUPLICATE_Z_TOLERANCE = 1e-6  # [m] largest |z_a(t) - z_b(t)| of a duplicate pair (mocap values are copied, not re-measured)


def duplicate_groups(tosses: list[Toss], tolerance: float = DUPLICATE_Z_TOLERANCE) -> list[list[int]]:
    """Indices into `tosses`, grouped so that tosses with the same z(t) (same length, every
    frame within `tolerance`) share a group; every index appears in exactly one group."""
    parent = list(range(len(tosses)))

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    by_length: dict[int, list[int]] = {}
    for i, toss in enumerate(tosses):
        by_length.setdefault(len(toss), []).append(i)
    for same in by_length.values():
        z = np.array([tosses[i].p_WB[:, 2] for i in same])  # (m, n)
        for a in range(len(same)):
            close = np.flatnonzero(np.max(np.abs(z[a + 1:] - z[a]), axis=1) <= tolerance) + a + 1
            for b in close:
                parent[root(same[b])] = root(same[a])
    groups: dict[int, list[int]] = {}
    for i in range(len(tosses)):
        groups.setdefault(root(i), []).append(i)
    return sorted(groups.values())


def parse_split(text: str) -> float:
    """'--split' value -> held-out fraction in [0, 1). 'none' or '0' = fit on everything."""
    if text.strip().lower() == "none":
        return 0.0
    try:
        fraction = float(text)
    except ValueError:
        fraction = float("nan")
    if not 0.0 <= fraction < 1.0:
        raise TestbedError(f"--split: expected the held-out fraction in [0, 1) or 'none', got {text!r}")
    return fraction


def train_test_split(tosses: list[Toss], test_fraction: float, seed: int = 0) -> tuple[list[int], list[int]]:
    """(train indices, test indices), sorted; duplicate groups never straddle the split.
    The test side takes whole groups in a seeded random order until it holds
    round(test_fraction * n) tosses (it may overshoot by a group)."""
    groups = duplicate_groups(tosses)
    order = np.random.default_rng(seed).permutation(len(groups))
    target = round(test_fraction * len(tosses))
    test: list[int] = []
    for g in order:
        if len(test) >= target:
            break
        test.extend(groups[g])
    test_set = set(test)
    return sorted(set(range(len(tosses))) - test_set), sorted(test_set)
