"""A pytest plugin for tests/project/test_tiers.py: at the end of collection, writes each collected
test's node id and marker names as JSON to the file TESTBED_TIER_MARKERS names (no test runs)."""

from __future__ import annotations

import json
import os


def pytest_collection_finish(session):
    out = os.environ.get("TESTBED_TIER_MARKERS")
    if out:
        rows = {item.nodeid: sorted({m.name for m in item.iter_markers()}) for item in session.items}
        with open(out, "w", encoding="utf-8") as f:
            json.dump(rows, f)
