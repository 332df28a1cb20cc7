"""The worst-case search (testbed/campaign/search.py, `testbed campaign --search`): the cross-entropy method
on a cheap synthetic objective (it finds the known maximum and beats as many random draws), its
determinism, refused runs kept out of the elite, a small search on a shipped family end to end (its worst
case written as a scene file that reproduces the recorded error, resumed without rerunning), a refused
proposal never simulated, and the bad flags refused with one line and exit status 2."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from testbed.campaign.family import TRUNCATE_SD, Varied, load_family
from testbed.campaign.search import CrossEntropySearch, bounds, maximise, objective

FAMILIES = Path(__file__).resolve().parents[2] / "testbed" / "families"

# a cheap objective over mixed fields: a concave bowl with its top inside the box, and a bonus for one choice
FIELDS = (Varied("x", "uniform", (0.0, 10.0)), Varied("y", "uniform", (-1.0, 1.0)), Varied("z", "normal", (5.0, 1.0)),
          Varied("kind", "choice", ("a", "b", "c", "d")))
TOP = {"x": 7.3, "y": -0.55, "z": 6.1, "kind": "c"}
BONUS = 0.1


def bowl(v: dict) -> float:
    return -(((v["x"] - TOP["x"]) / 10) ** 2 + ((v["y"] - TOP["y"]) / 2) ** 2 + ((v["z"] - TOP["z"]) / 6) ** 2) \
        + BONUS * (v["kind"] == TOP["kind"])


def _search(seed: int, budget: int, population=None):
    return maximise(lambda vectors, first, generation: [dict(v) for v in vectors], FIELDS, budget, seed, population,
                    score=bowl)


def test_the_search_finds_the_known_maximum_and_beats_as_many_random_draws():
    budget, best = 48, bowl(TOP)
    found, drawn = [], []
    for seed in range(5):
        _, tried, history = _search(seed, budget)
        assert len(tried) == budget and history[-1]["runs"][1] == budget - 1  # the budget spent, no more
        for v in tried:  # every proposal inside its field's support
            assert 0.0 <= v["x"] <= 10.0 and -1.0 <= v["y"] <= 1.0 and v["kind"] in "abcd"
            assert abs(v["z"] - 5.0) <= TRUNCATE_SD * 1.0 + 1e-12
        found.append(max(bowl(v) for v in tried))
        rng = np.random.default_rng(1000 + seed)  # the same number of independent draws from the family's distributions
        drawn.append(max(bowl({f.path: f.value(float(rng.random())) for f in FIELDS}) for _ in range(budget)))
        assert [h["best_so_far"] for h in history] == sorted(h["best_so_far"] for h in history)  # never forgets
    assert min(found) > best - 0.05, found  # close to the known maximum on every seed
    assert np.mean(found) > np.mean(drawn), (found, drawn)
    assert sum(f > d for f, d in zip(found, drawn)) >= 4, (found, drawn)


def test_the_search_concentrates_where_the_maximum_is():
    search, _, history = _search(0, 48, population=8)
    last = history[-1]["distribution"]
    assert abs(last["x"]["mean"] - TOP["x"]) < abs(5.0 - TOP["x"])  # moved from the box's centre towards the top
    assert last["x"]["sd"] < 10.0 / math.sqrt(12)  # narrower than the uniform it started from
    assert max(last["kind"]["probabilities"], key=last["kind"]["probabilities"].get) == TOP["kind"]
    lo, hi = bounds(FIELDS[2])
    assert (lo, hi) == (5.0 - TRUNCATE_SD, 5.0 + TRUNCATE_SD) and lo <= last["z"]["mean"] <= hi


def test_the_search_is_deterministic_for_a_seed():
    a, b, c = _search(3, 30), _search(3, 30), _search(4, 30)
    assert a[1] == b[1] and a[2] == b[2]  # the same proposals, the same history
    assert a[1] != c[1]
    first = CrossEntropySearch(FIELDS, 5, 3).propose()
    assert first == CrossEntropySearch(FIELDS, 5, 3).propose()


def test_refused_runs_never_join_the_elite():
    search = CrossEntropySearch(FIELDS, 4, 0)
    before = search.state()
    vectors = search.propose()
    search.tell(vectors, [-math.inf] * 4)  # every run refused: nothing to fit
    assert search.elite() == [] and search.state() == before
    vectors = search.propose()
    search.tell(vectors, [1.0, -math.inf, 2.0, -math.inf])
    assert sorted(s for _, s in search.elite()) == [1.0, 2.0] and search.state() != before
    assert objective({"status": "refused"}) == -math.inf and objective({"status": "error"}) == -math.inf
    assert objective({"status": "ok", "final_error_m": float("nan")}) == math.inf  # no final pose: as wrong as it gets
    assert objective({"status": "ok", "final_error_m": 0.004}) == 0.004


def test_a_search_writes_worst_cases_that_reproduce_their_error_and_resumes(tmp_path, capsys):
    from testbed.campaign.sample import judge, perturbation
    from testbed.cli import main
    from testbed.scenario import load_scenario

    out, family = tmp_path / "search", load_family(FAMILIES / "corner_drop.yaml")
    argv = ["campaign", "corner_drop", "--search", "--budget", "4", "--duration", "0.3", "--workers", "1", "--out", str(out)]
    status = main(argv)
    found = json.loads((out / "search.json").read_text())
    records = json.loads((out / "campaign.json").read_text())["samples"]
    assert status == (3 if any(not r["agree"] for r in records) else 0)
    assert [r["index"] for r in records] == [0, 1, 2, 3] and all(r["status"] == "ok" for r in records)
    assert [h["generation"] for h in found["history"]] == [0, 1] and [r["generation"] for r in records] == [0, 0, 1, 1]
    for h in found["history"]:  # each generation's best is its runs' largest final error
        first, last = h["runs"]
        assert h["best"] == max(r["final_error_m"] for r in records[first:last + 1])
    first_generation = [s["values"] for s in family.sample(4, 0)]
    assert [r["values"] for r in records[:2]] == first_generation[:2]  # where random sampling starts ...
    assert all(r["values"] not in first_generation for r in records[2:])  # ... then its own proposals
    errors = [w["final_error_m"] for w in found["worst"]]
    assert errors == sorted(errors, reverse=True) and errors[0] == max(r["final_error_m"] for r in records)
    worst = found["worst"][0]
    scenario = load_scenario(out / worst["scene"])  # the scene file loads as a scene, and reproduces its run
    twin = load_scenario(out / worst["scene"], overrides=perturbation(scenario, [v.path for v in family.varied]))
    assert scenario.duration == 0.3  # the duration it was judged over, not the family's
    again = judge(scenario, twin, scenario.duration, "improved")
    assert again["final_error_m"] == pytest.approx(worst["final_error_m"], rel=1e-6, abs=1e-12)
    assert again["classes"] == worst["classes"]
    html = (out / "index.html").read_text()
    assert "Search history" in html and "The worst cases found" in html and "Worst-case search" in html
    stamps = {p.name: p.stat().st_mtime_ns for p in (out / "search").iterdir()}
    capsys.readouterr()
    assert main(argv) == status
    assert "4 found done" in capsys.readouterr().out
    assert {p.name: p.stat().st_mtime_ns for p in (out / "search").iterdir()} == stamps  # nothing rerun
    assert json.loads((out / "search.json").read_text())["history"] == found["history"]


LIGHT = """
name: light_family
duration: 0.2
containers:
- {name: base, type: 1CC, mass: 20000.0, fixed: true, X_WC: {translation: [0.0, 0.0, 1.2955]}}
- {name: top, type: 1CC, mass: 10000.0, X_WC: {translation: [0.0, 0.0, 3.9]}}
effects: {contact: {}, friction: {}}
vary:
  containers[1].X_WC.translation[0]: {uniform: [-0.2, 0.2]}
  containers[1].mass: {uniform: [-30000.0, 10000.0]}
"""


def test_a_refused_proposal_is_never_simulated(tmp_path):
    from testbed.cli import main

    path, out = tmp_path / "light.yaml", tmp_path / "out"
    path.write_text(LIGHT)
    main(["campaign", str(path), "--search", "--budget", "4", "--workers", "1", "--out", str(out), "--quiet"])
    data = json.loads((out / "campaign.json").read_text())
    refused = [r for r in data["samples"] if r["status"] == "refused"]
    assert refused, "the mass range is mostly negative: some proposals must be refused"
    for r in refused:  # the field and the drawn value, and no run's figures
        assert r["refused"].startswith("containers[1].mass: ") and f"{r['values']['containers[1].mass']!r}" in r["refused"]
        assert "final_error_m" not in r and "classes" not in r
    assert not {r["index"] for r in refused} & {w["index"] for w in data["search"]["worst"]}
    assert all(r["values"]["containers[1].mass"] > 0 for r in data["samples"] if r["status"] == "ok")


@pytest.mark.parametrize("flags,message", [
    (["--search", "--budget", "0"], "--budget: expected 1 to"),
    (["--search", "--budget", "4", "--population", "9"], "--population: expected 1 to the budget (4)"),
    (["--search", "--samples", "4"], "--samples: not with --search"),
    (["--budget", "4"], "--budget: only with --search"),
])
def test_bad_search_flags_give_one_line_and_status_2(tmp_path, capsys, flags, message):
    from testbed.cli import main

    out = tmp_path / "out"
    assert main(["campaign", "corner_drop", *flags, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"testbed: error: {message}") and err.count("\n") == 1, err
    assert not out.exists()


def test_a_search_over_a_family_without_vary_gives_one_line_and_status_2(tmp_path, capsys):
    from testbed.cli import main

    path, out = tmp_path / "scene.yaml", tmp_path / "out"
    path.write_text(LIGHT.split("vary:")[0])
    assert main(["campaign", str(path), "--search", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("testbed: error: --search: ") and "vary" in err and err.count("\n") == 1, err
    assert not out.exists()
