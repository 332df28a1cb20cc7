"""The yard-size study in validate's report (case kind `scale`): its cells are ordinary
cases (JSON-able params, one per size and model) and its section is the study's own."""

import json

from testbed.document import Section
from testbed.validation.cases import Case, registry
from testbed.validation.cases.scale import SMOKE, VALIDATE


def test_the_default_suite_runs_three_sizes_of_every_model():
    kind = registry()["scale"]
    cases = kind.cases("default")
    assert {(c.params["task"]["n"], c.params["task"]["model"]) for c in cases} == \
        {(n, m) for n in VALIDATE.sizes for m in VALIDATE.model_names()}
    json.dumps([c.to_dict() for c in cases])  # what suite.json holds
    assert kind.cases("smoke") == []


def test_cells_run_and_the_section_reports_them():
    kind = registry()["scale"]
    cases = [Case(f"scale-{n}-{m}", "scale", {"task": {"config": c.params["task"]["config"], "n": n, "model": m}})
             for c in kind.cases("default")[:1] for n in SMOKE.sizes for m in ("point", "hydroelastic")]
    for case in cases:
        case.params["task"]["config"] = {**case.params["task"]["config"], "sizes": list(SMOKE.sizes),
                                         "duration": SMOKE.duration, "big_duration": SMOKE.duration,
                                         "models": ["hydroelastic", "point"]}
    records = [{"id": c.id, "params": c.params, "result": kind.run(**c.params)} for c in cases]
    assert all(r["result"]["status"] == "ok" for r in records), [r["result"].get("why") for r in records]
    # the truth is its own reference (0 error); point contact ends a measurable distance from it
    sections = kind.sections(records)
    assert all(isinstance(s, Section) for s in sections) and sections[0].title == "What a yard of N containers costs"
    from testbed.studies.scale import with_errors

    rows = with_errors([r["result"] for r in records])
    truth = [r for r in rows if r["model"] == "hydroelastic"]
    point = [r for r in rows if r["model"] == "point"]
    assert truth and all(r["final_position_error_m"] == 0.0 and r["simulated_s"] > 0 for r in truth)
    # point contact settles differently from the truth, but a yard at rest stays within 1 cm in 0.02 s
    assert point and all(0.0 <= r["final_position_error_m"] < 0.01 for r in point)
