"""Campaigns over scene families (testbed/campaign/, `testbed campaign`): the family file and its
samples, the refusal of a bad sample before it runs, the outcome classes, the Wilson interval, and a small
campaign run end to end and resumed."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from testbed.campaign.family import checked_sample, load_family
from testbed.campaign.sample import outcome
from testbed.campaign.verdict import summarise, wilson
from testbed.errors import ScenarioError
from testbed.simulation import Trajectory

FAMILIES = Path(__file__).resolve().parents[2] / "testbed" / "families"

DROP = """
name: drop_family
duration: 0.4
containers:
- {name: base, type: 1CC, mass: 20000.0, fixed: true, X_WC: {translation: [0.0, 0.0, 1.2955]}}
- {name: top, type: 1CC, mass: 10000.0, X_WC: {translation: [0.0, 0.0, 3.9]}}
effects: {contact: {}, friction: {}}
vary:
  containers[1].X_WC.translation[0]: {uniform: [-0.2, 0.2]}
  containers[1].X_WC.rotation.deg[0]: {uniform: [0.0, 0.4]}
  containers[1].mass: %s
campaign: {duration: 0.4, samples: 3}
"""


def _family(tmp_path, mass="{normal: [10000.0, 1000.0]}", text=DROP):
    path = tmp_path / "f.yaml"
    path.write_text(text % mass)
    return path


@pytest.mark.parametrize("path", sorted(FAMILIES.glob("*.yaml")), ids=lambda p: p.stem)
def test_every_shipped_family_loads_and_its_samples_are_scenes(path):
    family = load_family(path)
    samples = family.sample(8, 0)
    assert len(samples) == 8 and family.sample(8, 0) == samples and family.sample(8, 1) != samples  # seeded
    for s in samples:
        scenario, refused = checked_sample(family, s)
        assert refused is None and scenario is not None, refused
    for v in family.varied:  # every drawn value inside its distribution's support
        values = [s["values"][v.path] for s in samples]
        if v.kind == "uniform":
            assert min(values) >= v.args[0] and max(values) <= v.args[1]
        if v.kind == "normal":
            assert all(abs(x - v.args[0]) <= 3 * v.args[1] + 1e-9 for x in values)


def test_samples_set_the_fields_they_draw(tmp_path):
    family = load_family(_family(tmp_path))
    s = family.sample(3, 5)[2]
    scenario, _ = checked_sample(family, s)
    top = scenario.containers[1]
    assert top.pose().translation()[0] == pytest.approx(s["values"]["containers[1].X_WC.translation[0]"])
    assert top.mass == pytest.approx(s["values"]["containers[1].mass"])
    roll = np.degrees(top.pose().rotation().ToRollPitchYaw().vector()[0])
    assert roll == pytest.approx(s["values"]["containers[1].X_WC.rotation.deg[0]"], abs=1e-6)


@pytest.mark.parametrize("mass,match", [
    ("{gaussian: [1.0, 2.0]}", r"vary\.containers\[1\]\.mass: unknown distribution 'gaussian'"),
    ("{uniform: [5.0, 1.0]}", r"vary\.containers\[1\]\.mass\.uniform: expected lo < hi"),
    ("{normal: [1.0, -2.0]}", r"vary\.containers\[1\]\.mass\.normal: expected a standard deviation > 0"),
    ("{choice: []}", r"vary\.containers\[1\]\.mass\.choice: expected a list of 1 to 64 values"),
    ("[1, 2]", r"vary\.containers\[1\]\.mass: expected one distribution"),
])
def test_a_bad_distribution_is_refused_naming_the_field(tmp_path, mass, match):
    with pytest.raises(ScenarioError, match=match):
        load_family(_family(tmp_path, mass))


def test_a_family_without_vary_is_refused(tmp_path):
    path = tmp_path / "f.yaml"
    path.write_text(DROP.split("vary:")[0])
    with pytest.raises(ScenarioError, match="vary: expected a mapping of field paths"):
        load_family(path)


def test_a_bad_sample_is_refused_with_its_field_and_drawn_value(tmp_path):
    family = load_family(_family(tmp_path, "{uniform: [-20.0, -10.0]}"))
    scenario, refused = checked_sample(family, family.sample(1, 0)[0])
    drawn = family.sample(1, 0)[0]["values"]["containers[1].mass"]
    assert scenario is None and refused.startswith("containers[1].mass: ")
    assert refused.endswith(f"(drawn: {{'containers[1].mass': {drawn!r}}})"), refused


def _trajectory(p, q=None, V=None, error=""):
    p = np.asarray(p, dtype=float)
    n, m = p.shape[:2]
    q = np.tile([1.0, 0, 0, 0], (n, m, 1)) if q is None else np.asarray(q, dtype=float)
    V = np.zeros((n, m, 6)) if V is None else np.asarray(V, dtype=float)
    return Trajectory(time=np.arange(n) * 0.01, p_WB=p, q_WB=q, V_WB=V, energy=np.zeros(n), potential=np.zeros(n),
                      wall_s=0.0, simulated_s=0.01 * n, error=error)


def test_outcome_classes():
    start = [[0.0, 0.0, 3.0]]
    assert outcome(_trajectory([start, start])) == "seated"
    assert outcome(_trajectory([start, [[0.6, 0.0, 3.0]]])) == "slid"
    assert outcome(_trajectory([start, [[0.6, 0.0, 1.5]]])) == "fell"
    turned = [[[1.0, 0, 0, 0]], [[math.cos(math.radians(20)), math.sin(math.radians(20)), 0, 0]]]  # 40 deg
    assert outcome(_trajectory([start, start], q=turned)) == "tipped"
    moving = np.zeros((2, 1, 6))
    moving[-1, 0, 3] = 0.3
    assert outcome(_trajectory([start, start], V=moving)) == "moving"
    moving[-1, 0, 3] = 0.05  # a stack swaying after an impact: not still moving
    assert outcome(_trajectory([start, start], V=moving)) == "seated"
    assert outcome(_trajectory([start, start], error="diverged at t = 0.3 s")) == "diverged"


def test_wilson_interval_is_the_closed_form():
    for k, n in [(32, 32), (29, 32), (5, 10), (0, 7)]:
        z, p = 1.959963984540054, k / n
        centre, half = (p + z * z / (2 * n)) / (1 + z * z / n), z / (1 + z * z / n) * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
        assert wilson(k, n) == pytest.approx((centre - half, centre + half), abs=1e-9)
    assert wilson(32, 32)[0] > 0.8 > wilson(29, 32)[0]  # the gate: all 32 agreeing passes, 29 of 32 fails


def _record(i, agree, error=0.001, well_posed=True, status="ok"):
    return {"index": i, "status": status, "agree": agree, "final_error_m": error, "well_posed": well_posed,
            "truth_spread_m": 0.001, "classes": {"truth": "seated", "candidate": "seated" if agree else "slid"},
            "values": {}, "overrides": []}


def test_the_verdict_reads_the_interval_and_names_the_worst():
    passing = summarise([_record(i, True) for i in range(32)])
    assert passing["verdict"] == "PASS" and passing["agree"] == 32 and passing["interval_95"][0] > 0.8
    failing = summarise([_record(i, i >= 3, error=0.05 if i < 3 else 0.001) for i in range(32)])
    assert failing["verdict"] == "FAIL" and failing["worst"][:3] == [0, 1, 2]
    assert summarise([_record(0, True, status="refused")])["verdict"] == "FAIL"  # nothing judged
    few = summarise([_record(i, True) for i in range(6)])
    assert few["verdict"] == "UNDECIDED" and few["needed"] == 16  # all agree, too few to reach 0.8
    assert wilson(16, 16)[0] >= 0.8 > wilson(15, 15)[0]
    one_broken = [_record(i, True) for i in range(32)] + [{"index": 32, "status": "error", "error": "x"}]
    assert summarise(one_broken)["verdict"] == "FAIL"  # a sample that failed to run is not a pass


def test_a_campaign_runs_writes_its_report_and_resumes(tmp_path, capsys):
    from testbed.cli import main

    family, out = _family(tmp_path), tmp_path / "camp"
    status = main(["campaign", str(family), "--samples", "3", "--workers", "1", "--out", str(out)])
    data = json.loads((out / "campaign.json").read_text())
    assert status == 3 and data["summary"]["verdict"] == "UNDECIDED"  # 3 of 3 agree: too few to pass
    assert [r["index"] for r in data["samples"]] == [0, 1, 2] and all(r["status"] == "ok" for r in data["samples"])
    for r in data["samples"]:  # a level drop of 1 cm: seated in the truth, its twin and the loop alike
        assert r["classes"] == {"truth": "seated", "truth_perturbed": "seated", "candidate": "seated"}
        assert r["well_posed"] and r["final_error_m"] < 0.02
    html = (out / "index.html").read_text()
    assert "outcome in 3 of 3 samples of drop_family" in html and "run at least 16" in html  # lower end 0.44
    assert sorted(p.name for p in (out / "worst").iterdir()) == ["0000.yaml", "0001.yaml", "0002.yaml"]
    stamps = {p.name: p.stat().st_mtime_ns for p in (out / "samples").iterdir()}
    capsys.readouterr()
    main(["campaign", str(family), "--samples", "3", "--workers", "1", "--out", str(out)])
    assert "(3 already done)" in capsys.readouterr().out
    assert {p.name: p.stat().st_mtime_ns for p in (out / "samples").iterdir()} == stamps  # nothing rerun


def test_a_bad_predictor_or_family_name_is_refused_before_anything_runs(tmp_path):
    from testbed.cli import main

    assert main(["campaign", "corner_dorp", "--out", str(tmp_path / "a")]) == 2
    assert main(["campaign", str(_family(tmp_path)), "--predictor", "nope.npz", "--out", str(tmp_path / "b")]) == 2
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()
