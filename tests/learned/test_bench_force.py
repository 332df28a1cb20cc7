"""The bench's force section (testbed/bench/force.py): the law the loop runs against Drake's static
force on held-out poses, the former foundation beside it, and the section on the report's pages."""

from __future__ import annotations

import numpy as np

from learned_contact.data.labels import make_dataset
from testbed.bench.force import force_section
from testbed.bench.report import _force


def test_the_force_section_tells_the_exact_law_from_the_foundation():
    data = {"stacking": make_dataset("stacking", 400, 515151, progress=False),
            "general": make_dataset("general", 400, 525252, progress=False)}
    section = force_section(data)
    for name, s in section["sets"].items():
        exact, old = s["exact"], s["foundation"]
        assert s["n"] == len(data[name])
        # the exact answer: Drake's force to round-off, no zero answer, its stiffness Drake's derivative
        assert exact["force_rel_p95"] < 1e-9 and exact["zero_answers"] == 0 and exact["direction_p95_deg"] < 1e-6
        assert exact["stiffness_rel_p95"] < 1e-5
        # the foundation on the same poses: far off (measured 10x / 2,200x median), the figures can tell
        assert old["force_rel_median"] > 1.0 and old["stiffness_rel_median"] > 0.1
    lines = [b for sec in _force({"force": section}) for b in sec.blocks]
    assert lines, "the report shows the section"


def test_a_set_without_forces_is_left_out():
    ds = make_dataset("stacking", 50, 515152, progress=False)
    import dataclasses

    assert force_section({"bare": dataclasses.replace(ds, force=None)})["sets"] == {}
    assert np.isfinite(force_section({"s": ds})["sets"]["s"]["exact"]["force_rel_median"])
