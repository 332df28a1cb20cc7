"""The bench report's first screen (testbed/bench/first_screen.py, report.py, plots.py) on a
synthetic bench.json: the verdict table is the first block, its costs in microseconds before
the ratios, every cell bench.json's figure, Drake's point-pair spread from its rounds; the
shipped predictors run beside a user's model without being named; an ONNX model's metadata
name is its label. Nothing is timed here."""

from __future__ import annotations

import json

import pytest

from testbed.bench import first_screen, plots
from testbed.bench.report import write_bench

MINE, IMPROVED, PAPER = "models/exported_v3.onnx", "improved", "paper"
DRAKE_ROUNDS = [15.1e-6, 16.3e-6, 15.4e-6, 17.9e-6, 15.8e-6]  # [s per pair]


def _sets(scale: float) -> dict:
    out = {}
    for k, name in enumerate(("stacking", "general", "outside", "resting")):
        point = scale * 1e-3 * (k + 1)
        out[name] = {"n": 400, "point_median_m": point, "point_p95_m": 3 * point, "point_p99_m": 5 * point,
                     "normal_median_deg": 0.1 * scale, "normal_p95_deg": 0.3 * scale, "normal_p99_deg": 0.5 * scale,
                     "point_median_m_vs_prior": 0.5 * scale, "point_p95_m_vs_prior": 0.6 * scale,
                     "truth_gap_median_m": 1e-3, "point_median_m_vs_one_point": 2e-3}
    return out


def _entry(label: str, kind: str, single_s: float, batched_s: float, step_us: list, good: bool) -> dict:
    drake = min(DRAKE_ROUNDS)
    gate = {"name": "g", "passed": good}
    closed = {scene: {"passed": good, "gates": [gate], "duration_s": 1.0, "diverged": False,
                      "final_position_error_max_m": 1e-3, "final_angle_error_max_deg": 0.1, "max_penetration_m": 1e-3,
                      "speedup_vs_truth": 1.0, "cost_learned": {"predictor_us_per_step": us}}
              for scene, us in zip(("two_stack", "crane_misaligned", "overhang_tip"), step_us)}
    verdict = "GOOD ENOUGH: accuracy gates 2 of 2 passed" if good else "NOT GOOD ENOUGH: accuracy gates 1 of 2 passed"
    return {"label": label, "kind": kind, "name": label, "good_enough": good, "known_limits": [], "verdict": verdict,
            "accuracy": {"sets": _sets(1.0 if good else 7.0), "gates": [], "gates_passed": 2 if good else 1,
                         "gates_total": 2},
            "cost": {"first_call_s": 0.1, "single_s_per_pair": single_s, "batched_s_per_pair": batched_s,
                     "single_vs_drake_point": single_s / drake, "batched_vs_drake_point": batched_s / drake,
                     "single_vs_improved_compiled": single_s / 6e-6, "batched_vs_improved_compiled": batched_s / 4e-6},
            "in_scene": {"two_stack": {"duration_s": 1.0, "point_error_median_m": 1e-3, "point_error_max_m": 2e-3,
                                       "normal_error_median_deg": 0.1, "normal_error_max_deg": 0.2, "gates": [gate],
                                       "passed": good}},
            "closed_loop": closed}


@pytest.fixture()
def data() -> dict:
    predictors = {MINE: _entry("contact_net", "onnx", 41.7e-6, 2.93e-6, [80.0, 120.0, 95.0], good=False),
                  IMPROVED: _entry(IMPROVED, "improved", 6.34e-6, 4.37e-6, [3.5, 3.8, 7.9], good=True),
                  PAPER: _entry(PAPER, "paper", 2.9e-6, 0.84e-6, [2.0, 2.2, 2.1], good=True)}
    return {"schema": "testbed.bench/1", "quick": True, "seed": 0, "predictors": predictors,
            "references": {"drake_point_pair_set_pose_and_query_s_per_pair": min(DRAKE_ROUNDS),
                           "drake_point_pair_rounds_s_per_pair": DRAKE_ROUNDS,
                           "improved_compiled_single_s_per_pair": 6.34e-6, "improved_compiled_batched_s_per_pair": 4.37e-6,
                           "single_pairs": 200, "batch": 1000, "repeats": 2},
            "leaderboard": [IMPROVED, PAPER, MINE], "judged": [MINE]}


def _first_table(markdown: str) -> list[list[str]]:
    """The first pipe table of a Markdown document, header row first (the separator dropped)."""
    lines = markdown.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("|"))
    rows = []
    for line in lines[start:]:
        if not line.startswith("|"):
            break
        if not line.startswith("|---"):
            rows.append([c.strip() for c in line.strip().strip("|").split(" | ")])
    return rows


def test_the_first_screen_is_the_verdict_table_of_the_json_s_figures(data, tmp_path):
    write_bench(tmp_path / "out", data)
    on_disk = json.loads((tmp_path / "out" / "bench.json").read_text())
    markdown = (tmp_path / "out" / "summary.md").read_text()
    head, *body = _first_table(markdown)
    # the first table comes before any section, and it is the verdict table: costs [us] first, ratios second
    assert markdown.index("| predictor |") < markdown.index("## Leaderboard")
    assert head == [h for _, h in first_screen.COLUMNS]
    us = [i for i, h in enumerate(head) if h.startswith("us/")]
    ratios = [i for i, h in enumerate(head) if "/ Drake" in h]
    assert len(us) == 3 and len(ratios) == 2 and max(us) < min(ratios)
    # the user's model first, then the shipped references (none of them named by the user: roles), then Drake
    assert [(r[0], r[1]) for r in body] == [("contact_net", "judged"), (IMPROVED, "reference"), (PAPER, "reference"),
                                            (first_screen.DRAKE, "cost reference")]
    for row, spec in zip(body, (MINE, IMPROVED, PAPER)):
        e = on_disk["predictors"][spec]
        c = e["cost"]
        assert row[2] == e["verdict"].split(":")[0]
        assert row[3] == format(c["single_s_per_pair"] * 1e6, ".3g")  # [us], the JSON's [s] figure
        assert row[4] == format(c["batched_s_per_pair"] * 1e6, ".3g")
        steps = sorted(f["cost_learned"]["predictor_us_per_step"] for f in e["closed_loop"].values())
        assert row[5] == format(steps[1], ".3g")  # the median of the three scenes
        assert row[6] == format(c["single_vs_drake_point"], ".2g")
        assert row[7] == format(c["batched_vs_drake_point"], ".2g")
        assert row[8] == f"{e['accuracy']['gates_passed']}/{e['accuracy']['gates_total']}"
        assert row[10] == f"{sum(f['passed'] for f in e['closed_loop'].values())}/{len(e['closed_loop'])}"
    # Drake's row: its fastest round, and the spread of its rounds in the same run
    drake = body[-1][3]
    assert float(drake.split()[0]) == pytest.approx(min(DRAKE_ROUNDS) * 1e6, rel=1e-3)
    spread = drake.split("min-max ")[1].split(",")[0]
    assert [float(v) for v in spread.split("-")] == pytest.approx([min(DRAKE_ROUNDS) * 1e6, max(DRAKE_ROUNDS) * 1e6],
                                                                    rel=1e-3)
    assert f"{len(DRAKE_ROUNDS)} rounds" in drake
    # the headline above it speaks of the user's model alone, which fails
    assert markdown.split("\n\n")[1] == "**FAIL**: contact_net: NOT GOOD ENOUGH"


def test_the_plot_draws_every_model_and_the_reference(data):
    drawn = plots.points(data)
    assert [p["label"] for p in drawn] == ["contact_net", IMPROVED, PAPER]
    assert [p["role"] for p in drawn] == ["judged", "reference", "reference"]
    mine = drawn[0]
    assert mine["us"] == pytest.approx((41.7, 2.93)) and mine["p95_cm"] == pytest.approx(3 * 7.0e-3 * 100)
    assert first_screen.drake_figures(data) == pytest.approx({"best_us": 15.1, "min_us": 15.1, "max_us": 17.9, "rounds": 5})
    assert plots.set_names(data) == ["stacking", "general", "outside", "resting"]
    assert plots.figure(data).png[:8] == b"\x89PNG\r\n\x1a\n"


def test_an_old_bench_json_without_drake_s_rounds_still_renders(data):
    del data["references"]["drake_point_pair_rounds_s_per_pair"]
    drake = first_screen.cells(first_screen.rows(data)[-1])
    assert drake[3] == f"{min(DRAKE_ROUNDS) * 1e6:.3g}"  # the fastest alone, no spread claimed


def test_the_shipped_predictors_run_beside_a_model_without_being_named(monkeypatch):
    from testbed.bench import run

    assert run.with_references([MINE]) == [MINE, IMPROVED, PAPER]
    assert run.with_references([MINE, PAPER]) == [MINE, PAPER, IMPROVED]
    assert run.with_references([MINE], references=False) == [MINE]
    assert run.with_references([]) == [IMPROVED, PAPER]
    asked = []

    def resolve(spec):  # bench() resolves every model first: record which, then stop
        asked.append(spec)
        if len(asked) == 3:
            raise RuntimeError("stop")
        return spec

    monkeypatch.setattr(run, "resolve", resolve)
    with pytest.raises(RuntimeError, match="stop"):
        run.bench([MINE], progress=False)
    assert asked == [MINE, IMPROVED, PAPER]


def test_an_onnx_model_s_metadata_name_is_its_label(tmp_path):
    pytest.importorskip("onnxruntime", reason="pip install onnxruntime==1.30.0")
    import bench_models as bm

    from testbed.bench.model import distinct_labels, resolve

    named = resolve(str(bm.centre_line_onnx(tmp_path / "export_2026_12_07.onnx", name="my contact net")))
    assert named.label == "my_contact_net" and named.name == "my contact net"
    twin = resolve(str(bm.centre_line_onnx(tmp_path / "other_file.onnx", name="my contact net")))
    # two files of one metadata name: each labelled by its file's stem instead
    assert [m.label for m in distinct_labels([named, twin])] == ["export_2026_12_07", "other_file"]
    assert resolve("bench_models:GeometricModel").label == "GeometricModel"  # a Python model: its attribute
