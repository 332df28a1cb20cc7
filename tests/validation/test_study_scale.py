"""Scale study (testbed.studies.scale, `testbed study scale`): yard layouts, the growth fit,
errors against the reference, a tiny run of every model, the report, the executors and the
command's one-line errors; the bench's yard budget (testbed.bench.yard_budget). Never asserts
absolute times (2 shared cores)."""

import dataclasses
import functools
import json
import math

import numpy as np
import pytest

pytest.importorskip("matplotlib", reason="pip install -e '.[study]'")

from testbed.bench import yard_budget  # noqa: E402
from testbed.cli import main  # noqa: E402
from testbed.document import to_markdown  # noqa: E402
from testbed.engines import engines  # noqa: E402
from testbed.scenario import load_scenario  # noqa: E402
from testbed.studies import scale  # noqa: E402
from testbed.validation.executors import map_calls  # noqa: E402

TINY = scale.ScaleConfig(sizes=(4, 8), duration=0.01, big_duration=0.005, big_above=4, fit_from=4, repeats=1)


@pytest.fixture(scope="module")
def tiny_study():
    return scale.run_study(TINY)


def test_layout_is_as_square_as_the_stack_count_allows():
    assert scale.layout(4, 4) == (1, 1, 4)
    assert scale.layout(16, 4) == (2, 2, 4)
    assert scale.layout(48, 4) == (3, 4, 4)
    assert scale.layout(96, 4) == (4, 6, 4)
    assert scale.layout(192, 4) == (6, 8, 4)
    assert scale.layout(28, 4) == (1, 7, 4)
    assert scale.layout(12, 3) == (2, 2, 3)


def test_the_96_container_yard_is_the_shipped_yard_block():
    built = scale.yard_scenario(96, scale.ScaleConfig())
    shipped = load_scenario("yard_block")
    assert [c.name for c in built.containers] == [c.name for c in shipped.containers]
    assert [c.mass for c in built.containers] == [c.mass for c in shipped.containers]
    assert np.allclose([c.pose().translation() for c in built.containers],
                       [c.pose().translation() for c in shipped.containers])
    assert built.duration == scale.ScaleConfig().duration  # 96 is not above big_above
    assert built.plant.time_step == 1e-3
    # the dynamics alone: no recorder, no learned loop (the learned engines add theirs)
    assert built.effects.contact_log is None and built.effects.learned_dynamics is None


@pytest.mark.parametrize("change, option", [
    ({"sizes": (5,)}, "--sizes"), ({"sizes": ()}, "--sizes"), ({"sizes": (4, 4)}, "--sizes"),
    ({"sizes": (2000,)}, "--sizes"), ({"models": ("bullet",)}, "--models"), ({"duration": 0.0}, "--duration"),
    ({"big_duration": math.nan}, "--big-duration"), ({"tiers": 0}, "--tiers"), ({"repeats": 0}, "--repeats"),
    ({"time_step": 0.5}, "--time-step")])
def test_bad_settings_are_one_line_errors_naming_the_option(change, option):
    with pytest.raises(scale.ScaleConfigError) as e:
        dataclasses.replace(TINY, **change).validate()
    assert str(e.value).startswith(option) and "\n" not in str(e.value)


def _row(n, model, us, status="ok"):
    return {"n": n, "model": model, "us_per_step": us, "status": status}


def test_growth_fit_is_the_log_log_slope_from_fit_from_up():
    rows = [_row(n, "point", 3.0 * n**1.5) for n in (16, 48, 96)] + [_row(4, "point", 1e6)]  # N=4 left out
    rows += [_row(192, "point", 1.0, status="diverged")]  # an incomplete run is not fitted
    rows += [_row(16, "mujoco", 5.0)]  # one size: no fit
    fits = scale.growth_fits(rows, ("point", "mujoco"), fit_from=16)
    assert fits["point"]["exponent"] == pytest.approx(1.5)
    assert fits["point"]["prefactor_us"] == pytest.approx(3.0)
    assert fits["point"]["sizes"] == [16, 48, 96]
    assert math.isnan(fits["mujoco"]["exponent"])


def test_errors_are_against_the_reference_of_the_same_size():
    p = np.zeros((2, 3))
    q = np.tile([1.0, 0.0, 0.0, 0.0], (2, 1))
    base = {"status": "ok", "simulated_s": 0.1, "time_step_s": 1e-3, "q_final": q.tolist()}
    rows = [{**base, "n": 4, "model": "hydroelastic", "p_final": p.tolist()},
            {**base, "n": 4, "model": "point", "p_final": (p + [[0.0, 0.0, 0.003], [0.004, 0.0, 0.0]]).tolist()},
            {**base, "n": 4, "model": "learned", "status": "diverged", "simulated_s": 0.05, "p_final": p.tolist()},
            {**base, "n": 8, "model": "point", "p_final": p.tolist()}]  # no reference at N = 8
    out = scale.with_errors(rows)
    assert out[0]["final_position_error_m"] == 0.0
    assert out[1]["final_position_error_m"] == pytest.approx(0.004)
    assert out[1]["final_angle_error_deg"] == pytest.approx(0.0, abs=1e-9)
    assert math.isnan(out[2]["final_position_error_m"]) and math.isnan(out[3]["final_position_error_m"])
    assert all("p_final" not in r and "q_final" not in r for r in out)


def test_targets_read_the_issue_s_figures():
    def row(n, model, us, rtf=1.0, pos=0.0, ang=0.0):
        return {"n": n, "model": model, "status": "ok", "us_per_step": us, "real_time_factor": rtf,
                "final_position_error_m": pos, "final_angle_error_deg": ang}

    rows = [row(n, "learned", 10.0 * n) for n in (16, 48, 96)] + [row(192, "learned", 1e9)]  # 192: outside 16-96
    rows += [row(n, "point", 5.0 * n) for n in (16, 96)]
    rows += [row(16, "mujoco_learned", 20.0), row(96, "mujoco_learned", 40.0, rtf=2.5, pos=0.03, ang=0.1)]
    out = {x["target"]: x for x in scale.targets({"rows": rows})}
    learned = next(x for k, x in out.items() if k.startswith("learned loop (in Drake): per-step growth"))
    assert learned["measured"] == "1.00" and learned["met"] is True
    hosted = next(x for k, x in out.items() if k.startswith("learned loop (in MuJoCo): per-step growth"))
    assert hosted["measured"] == "0.39" and hosted["met"] is True
    assert next(x for k, x in out.items() if "real time" in k)["met"] is True
    assert next(x for k, x in out.items() if "faster than Drake point" in k)["measured"] == "12.0x"
    assert next(x for k, x in out.items() if "final position" in k)["met"] is False  # 3 cm
    slower = next(x for k, x in out.items() if "no slower" in k)
    assert slower["met"] is False and slower["measured"].startswith("slower at N = 16 (2.00x), 96")
    assert all(x["met"] is None for x in scale.targets({"rows": []}))


def test_every_model_runs_a_tiny_yard(tiny_study):
    rows = tiny_study["rows"]
    assert [(r["n"], r["model"]) for r in rows] == [(n, m) for n in TINY.sizes for m in TINY.models]
    by = {(r["n"], r["model"]): r for r in rows}
    for n in TINY.sizes:
        for m in ("hydroelastic", "point", "learned"):
            assert by[n, m]["status"] == "ok", by[n, m]
        assert by[n, "mujoco_learned"]["status"] in ("ok", "unavailable")
        assert by[n, "mujoco"]["status"] in ("ok", "unavailable")
        assert by[n, "hydroelastic"]["final_position_error_m"] == 0.0
    # the shorter runs above big_above, as the report says
    assert by[4, "point"]["simulated_s"] == pytest.approx(0.01) and by[8, "point"]["simulated_s"] == pytest.approx(0.005)
    for r in rows:
        if r["status"] != "ok":
            continue
        assert r["steps"] == round(r["simulated_s"] / 1e-3) and r["us_per_step"] > 0
        assert r["real_time_factor"] == pytest.approx(r["simulated_s"] / r["wall_s"])
        split = r["split_us"]
        if r["model"] in ("learned", "mujoco_learned"):  # the learned loop's parts add up to its step
            assert sum(split.values()) == pytest.approx(r["us_per_step"], rel=1e-6)
            assert r["pairs_per_step"] > 0
        else:  # the engine's own contact is inside its step
            assert split == {"engine_step": r["us_per_step"], "learned_system": None, "predictor": None}
        if r["model"] != "hydroelastic":  # a yard settling from rest: every model lands within a centimetre
            assert r["final_position_error_m"] < 0.01, r
    assert set(tiny_study["fits"]) == set(TINY.models)
    json.dumps(tiny_study)  # JSON-able


def test_report_files_and_what_they_say(tiny_study, tmp_path):
    paths = scale.write_report(tiny_study, tmp_path / "out")
    names = {p.name for p in paths}
    assert names == {"scale.json", "scale.md", "scale.html", "scale_cost.png"}
    assert (tmp_path / "out" / "scale_cost.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    md = (tmp_path / "out" / "scale.md").read_text()
    assert "SHORTER at the big sizes: 0.005 s at N = 8" in md
    assert "real time" in md.lower() and "growth exponent" in md
    for label in scale.LABELS.values():
        assert label in md
    assert "<img src='data:image/png;base64," in (tmp_path / "out" / "scale.html").read_text()
    assert json.loads((tmp_path / "out" / "scale.json").read_text())["schema"] == scale.SCHEMA
    lines = scale.summary_lines(tiny_study)
    assert len(lines) == len(TINY.models) and lines[0].startswith("Drake hydroelastic")


def test_an_engine_not_registered_reads_unavailable(monkeypatch):
    known = {k: v for k, v in engines().items() if k != scale.MUJOCO_LEARNED}
    monkeypatch.setattr(scale, "engines", lambda: known)
    config = dataclasses.replace(TINY, sizes=(4,), models=("mujoco_learned",))
    row = scale.run_cell(scale.tasks(config)[0])
    assert row["status"] == "unavailable" and "mujoco_learned" in row["why"]
    study = scale.run_study(config)
    assert math.isnan(study["fits"]["mujoco_learned"]["exponent"])
    assert "no completed run" in scale.summary_lines(study)[0]


def test_cells_run_through_validates_local_executor():
    config = dataclasses.replace(TINY, sizes=(4,), models=("point", "mujoco"))
    study = scale.run_study(config, map_cells=functools.partial(map_calls, executor="local", workers=2), executor="local")
    assert [(r["n"], r["model"]) for r in study["rows"]] == [(4, "point"), (4, "mujoco")]
    assert study["rows"][0]["status"] == "ok" and study["executor"] == "local"


@pytest.mark.slow
def test_cells_run_through_ray():
    pytest.importorskip("ray")
    config = dataclasses.replace(TINY, sizes=(4,), models=("point",))
    study = scale.run_study(config, map_cells=functools.partial(map_calls, executor="ray"), executor="ray")
    assert study["rows"][0]["status"] == "ok"


@pytest.mark.parametrize("argv, message", [
    (["--sizes", "5"], "--sizes: expected multiples"), (["--sizes", "4,x"], "--sizes: expected comma-separated"),
    (["--models", "bullet"], "--models: unknown"), (["--quick", "--duration", "-1"], "--duration")])
def test_bad_flags_exit_2_with_one_line_and_write_nothing(argv, message, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["study", "scale", "--out", str(out), *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and "\n" not in err
    assert not out.exists()


def test_the_command_writes_the_report(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["study", "scale", "--quick", "--quiet", "--sizes", "4", "--models", "point,mujoco", "--duration", "0.005",
                 "--out", str(out)]) == 0
    assert (out / "scale.md").is_file() and (out / "scale_cost.png").is_file()
    assert "Drake point" in capsys.readouterr().out


# ----------------------------------------------------------------------------- the bench's yard budget


def test_budget_arithmetic():
    assert yard_budget.pairs_within(1e-3, 1e-4, 1e-6) == 900
    assert yard_budget.pairs_within(1e-4, 2e-4, 1e-6) == 0  # the fixed cost alone overruns the step
    a, b = yard_budget.fit_call_cost([1, 8, 32, 128], [5e-6 + 2e-6 * k for k in (1, 8, 32, 128)])
    assert a == pytest.approx(5e-6) and b == pytest.approx(2e-6)
    p, R, sA, sB = yard_budget.stacking_poses(50)
    assert p.shape == (50, 3) and R.shape == (50, 3, 3) and sA.shape == sB.shape == (50, 3)
    assert np.allclose(R @ np.swapaxes(R, 1, 2), np.eye(3), atol=1e-12)
    assert np.all(p[:, 2] <= sA[:, 2]) and np.all(p[:, 2] >= sA[:, 2] - 2e-3)  # B rests on A, slightly overlapping


def test_budget_of_a_predictor_beside_a_given_host_step():
    host = {"model": "given", "n": 96, "host_step_s": 4e-4, "learned_system_s": 1e-4, "pairs_per_step": 72.0}
    settings = yard_budget.BudgetSettings(batch_sizes=(1, 16, 64), repeats=1, host=host)
    budget = yard_budget.yard_budget(["paper"], settings)
    entry = budget["predictors"]["paper"]
    assert len(entry["call_s"]) == 3 and entry["per_pair_s"] > 0
    assert entry["pairs_within_step"] == yard_budget.pairs_within(6e-4, entry["fixed_s"], entry["per_pair_s"])
    assert entry["pairs_beside_loop"] == yard_budget.pairs_within(5e-4, entry["fixed_s"], entry["per_pair_s"])
    assert entry["pairs_beside_loop"] <= entry["pairs_within_step"]
    md = to_markdown("bench", [yard_budget.budget_section(budget)])
    assert "Yard budget" in md and "| paper |" in md


def test_host_step_is_measured_on_a_yard():
    host = yard_budget.host_step(host_size=4, duration=0.01)
    assert host["model"] in yard_budget.HOST_MODELS and host["n"] == 4
    assert host["host_step_s"] > 0 and host["learned_system_s"] >= 0 and host["pairs_per_step"] == pytest.approx(3.0)
