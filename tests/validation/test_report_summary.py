"""The validate report's first screen from hand-made gates and records (no case runs):
counts, the known-limits list, quick-mode flags, the gate table's order, the TOC anchors."""

from testbed.document import Section, Text, to_html
from testbed.validation.cases import registry
from testbed.validation.report import sections
from testbed.validation.summary import gate_counts, headline, limit_line


def _gate(name, passed, value=0.001, threshold=0.02, bound=None):
    g = {"name": name, "passed": passed, "value": value, "threshold": threshold, "unit": "m", "description": "d"}
    if bound is not None:
        g["bound"] = bound
    return g


GATES = [_gate("a: final position", True), _gate("b: final position (known limit)", True, 1.744, [0.504, 2.016], 0.02),
         _gate("c: max penetration", False, 0.05, 0.02), _gate("d: energy", True)]


def test_counts_and_headline_keep_passes_limits_and_failures_apart():
    assert gate_counts(GATES) == {"passed": 2, "known_limits": 1, "failed": 1}
    assert headline(GATES) == "1 of 4 gates fail; 2 gates pass, 1 hold only within pinned known limits (listed below)."
    # the figure, the bound it misses (both in mm) and the band it is pinned to
    assert limit_line(GATES[1]) == ("b: final position (known limit): 1744 mm against the 20 mm bound "
                                    "(pinned band [504 mm, 2016 mm])")


def test_failures_then_limits_first_in_the_gate_table_and_limits_listed():
    metrics = {"gates": GATES, "passed": False, "replays": {}, "created": "now",
               "environment": {"drake": "x", "python": "3", "cpus": 2}}
    parts = sections(metrics, [])
    html = to_html("t", parts)
    table = html.split("<h2 id='all-gates'>")[1]
    order = [table.index(g["name"] + "<") for g in (GATES[2], GATES[1], GATES[0], GATES[3])]
    assert order == sorted(order), order
    limits = next(s for s in parts if s.title == "Known limits")
    assert "b: final position (known limit)" in str(limits.blocks)
    assert "FAILED c: max penetration: 50 mm (threshold 20 mm)" in html


def test_quick_mode_is_flagged_from_the_records():
    query = registry()["query_study"]
    record = {"params": {"quick": True}, "result": {"metrics": {"config": {"n_poses": 24, "repeats": 3}}}}
    assert "24 poses per set" in query.quick([record])
    assert query.quick([{**record, "params": {"quick": False}}]) is None
    stability = registry()["stability"]
    assert stability.quick([{"params": {"entries": [["x", {}]] * 6}}]).startswith("the stability matrix (6 of ")


def test_table_of_contents_links_every_section_to_a_unique_anchor():
    parts = [Section(t, [Text("x")]) for t in ("Closed loop: one", "Closed loop: one", "Scenes")]
    html = to_html("t", parts)
    for anchor in ("closed-loop-one", "closed-loop-one-2", "scenes"):
        assert f"href='#{anchor}'" in html and f"id='{anchor}'" in html
    assert "<nav" not in to_html("t", parts[:2])  # two sections need no contents line


def test_polygon_soup_is_a_candidate_on_the_first_screen():
    """The paper's baseline, named plainly, at the coarsest and finest mesh the query study timed."""
    from testbed.validation.summary import soup_rows

    def method(n, err, us):
        return {"N": n, "all": {"point_error_m": {"median": err}, "time_us": {"median": us}}}

    rows = soup_rows({"soup_N8": method(8, 0.224, 545.0), "soup_N12": method(12, 0.15, 900.0),
                      "soup_N22": method(22, 0.08, 2500.0), "improved_single": method(None, 0.011, 10.0)})
    assert [r[0].split(",")[0] for r in rows] == ["polygon soup", "polygon soup"]
    assert "768 triangles per box" in rows[0][0] and "5,808 triangles per box" in rows[1][0]
    assert rows[0][1].startswith("224") and rows[0][4].startswith("545") and rows[1][4].startswith("2500")
