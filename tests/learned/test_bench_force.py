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


def test_the_section_shows_the_step_cost_with_its_verdicts():
    from testbed.bench.force import step_cost_rows
    from testbed.document import to_markdown

    rows = step_cost_rows(budget_s=0.005)
    assert set(rows) == {"yard block (72 resting pairs)", "nine mixed stack (8 pairs)", "slide on a box",
                         "tilted drop, landed"}
    assert all(r["exact_us"] > 0 and r["foundation_us"] > 0 and r["ratio"] > 0 for r in rows.values())
    section = {"law": "x", "modulus_Pa": 1e8, "sets": {}, "step_cost": rows}
    text = to_markdown("bench", _force({"force": section}))
    assert "exact / foundation" in text and all(f"{r['ratio']:.2f}x" in text for r in rows.values())
