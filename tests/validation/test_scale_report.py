"""The scale study's report writer (testbed/studies/scale/report.py) on a small synthetic
result (no yard is simulated): the fits table comes first in its section, the long key after
it, its cells the study's fits; the log-log chart labels at least 3 y ticks, on a wide range
and on a narrow one."""

from __future__ import annotations

import dataclasses
import math

import pytest

pytest.importorskip("matplotlib", reason="pip install -e '.[study]'")

from testbed.document import to_markdown  # noqa: E402
from testbed.studies.scale import report  # noqa: E402
from testbed.studies.scale.fit import pass_fits, yard_fits  # noqa: E402
from testbed.studies.scale.settings import ScaleConfig, label  # noqa: E402

SIZES = (96, 192, 480)


def _row(n: int, model: str, us: float, yard: str, run: int) -> dict:
    return {"n": n, "model": model, "yard": yard, "pass": run, "status": "ok", "why": "", "layout": "4 x 6 x 4",
            "simulated_s": 0.1, "us_per_step": us, "cpu_us_per_step": 0.9 * us, "real_time_factor": 1e3 / us,
            "cpu_real_time_factor": 1e3 / (0.9 * us), "pairs_per_step": 1.5 * n, "final_position_error_m": 1e-4,
            "split_us": {"engine_step": us / 2, "learned_system": us / 3, "predictor": us / 6},
            "start_max_speed_mps": 1e-4, "start_kinetic_J": 0.1, "settle_peak_kinetic_J": 50.0,
            "start_asleep_fraction": 0.9, "asleep_fraction": 0.95, "landed": True, "start_load_clearance_m": 0.001}


def study(costs: dict) -> dict:
    """A study record of `costs` (model -> (a, b): us per step = a (N / 96)^b), both yards, two passes."""
    config = ScaleConfig(sizes=SIZES, models=tuple(costs), caps=(), passes=2)
    rows = [_row(n, m, a * (n / 96) ** b * (1.0 + 0.02 * run), y, run)
            for run in (1, 2) for n in SIZES for m, (a, b) in costs.items() for y in config.yards]
    models = config.model_names()
    return {"schema": "testbed.study.scale/2", "config": dataclasses.asdict(config), "rows": rows,
            "fits": yard_fits(rows, models, config.fit_from, config.yards),
            "pass_fits": pass_fits(rows, models, config.fit_from, config.yards, config.passes),
            "environment": {"python": "3.11", "machine": "x86_64", "cpus": 2, "drake": "1.51.1", "engines": {}},
            "executor": "sequential", "wall_s": 12.0}


def _labelled_y_ticks(fig) -> list[str]:
    fig.canvas.draw()
    ax = fig.axes[0]
    low, high = ax.get_ylim()
    return [t.get_text() for t, v in zip(ax.get_yticklabels(), ax.get_yticks()) if t.get_text() and low <= v <= high]


def test_the_fits_table_comes_before_the_key_and_holds_the_fits():
    data = study({"learned": (300.0, 0.9), "hydroelastic": (800.0, 1.3)})
    first = report.report_sections(data)[0]
    assert [type(b).__name__ for b in first.blocks] == ["Table", "Text", "Text"]
    markdown = to_markdown(report.TITLE, [first])
    assert markdown.index("| model | yard |") < markdown.index("Each run first SETTLES")
    rows = {(r[0], r[1]): r for r in first.blocks[0].rows}
    for m in ("learned", "hydroelastic"):
        for y in ("settled", "crane"):
            row = rows[label(m), y]
            pooled = data["fits"][y][m]
            assert row[4].split(" +- ")[0] == f"{pooled['exponent']:.2f}"  # passes pooled, after passes 1 and 2
            assert [row[k].split(" +- ")[0] for k in (2, 3)] == [f"{data['pass_fits'][p][y][m]['exponent']:.2f}"
                                                               for p in ("1", "2")]
            slowest = max((r for r in data["rows"] if (r["model"], r["yard"], r["n"]) == (m, y, max(SIZES))),
                          key=lambda r: r["us_per_step"])
            assert row[5] == f"{slowest['us_per_step']:.0f} us at N={max(SIZES)}"
    assert math.isclose(data["fits"]["settled"]["learned"]["exponent"], 0.9, abs_tol=0.01)


@pytest.mark.parametrize("costs", [{"learned": (300.0, 0.9), "hydroelastic": (800.0, 1.3)},  # ~300-2700 us
                                   {"learned": (420.0, 0.2)}])  # ~420-560 us and the 1000 us line: under a decade
def test_the_log_log_chart_labels_at_least_three_y_ticks(costs):
    data = study(costs)
    fig = report.cost_figure(data["rows"], data["fits"], ScaleConfig(sizes=SIZES, models=tuple(costs), caps=()))
    labels = _labelled_y_ticks(fig)
    assert len(labels) >= 3, labels
    assert all(float(t) > 0 for t in labels)  # plain numbers, read as they are


def test_the_report_files_are_written(tmp_path):
    paths = report.write_report(study({"learned": (300.0, 0.9)}), tmp_path / "out")
    assert {p.name for p in paths} == {"scale.json", "scale.md", "scale.html", "scale_cost.png"}
    html = (tmp_path / "out" / "scale.html").read_text()
    assert html.index("<table>") < html.index("Each run first SETTLES")
