"""Scale study (testbed.studies.scale, `testbed study scale`): yard layouts, the models read
from the engine registry, the settled window (timed past the transient), the growth fit on
synthetic data, errors against the reference, a tiny run of every model and both yards, the
report, the executors and the command's one-line errors; the bench's yard budget
(testbed.bench.yard_budget). Never asserts absolute times (2 shared cores)."""

import dataclasses
import functools
import json
import math

import numpy as np
import pytest

pytest.importorskip("matplotlib", reason="pip install -e '.[study]'")

from testbed.bench import yard_budget  # noqa: E402
from testbed.bodies.containers import CONTAINER_TYPES  # noqa: E402
from testbed.cli import main  # noqa: E402
from testbed.document import to_markdown  # noqa: E402
from testbed.engines import engines  # noqa: E402
from testbed.engines.base import Engine  # noqa: E402
from testbed.engines.candidate import Candidate  # noqa: E402
from testbed.scenario import load_scenario  # noqa: E402
from testbed.studies import scale  # noqa: E402
from testbed.studies.scale import cells, settings, targets  # noqa: E402
from testbed.validation.executors import map_calls  # noqa: E402

TINY = scale.ScaleConfig(sizes=(4, 8), settle_s=0.01, duration=0.01, big_duration=0.005, big_above=4, caps=(), fit_from=4,
                         passes=1, repeats=1)
SHIPPED = ("hydroelastic", "point", "learned", "mujoco", "mujoco_learned")


@pytest.fixture(scope="module")
def tiny_study():
    return scale.run_study(TINY)


def test_layout_is_as_square_as_the_stack_count_allows():
    assert scale.layout(4, 4) == (1, 1, 4)
    assert scale.layout(16, 4) == (2, 2, 4)
    assert scale.layout(48, 4) == (3, 4, 4)
    assert scale.layout(96, 4) == (4, 6, 4)
    assert scale.layout(192, 4) == (6, 8, 4)
    assert scale.layout(480, 4) == (10, 12, 4)
    assert scale.layout(1000, 4) == (10, 25, 4)
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


def test_the_crane_yard_hangs_its_load_over_the_middle_stack():
    config = scale.ScaleConfig()
    built = scale.yard_scenario(1000, config, "crane")
    by = {c.name: c for c in built.containers}
    assert len(built.containers) == 1001 and scale.crane_stack(1000, config) == (5, 13)
    top, load = by["blk_r5_b13_t4"].pose().translation(), by["load"].pose().translation()
    height = CONTAINER_TYPES["1AA"].size[2]
    # straight above the top container, crane_gap clear of it (both 1AA: one container height apart plus the gap)
    assert np.allclose(load[:2], top[:2], atol=1e-9) and load[2] - top[2] == pytest.approx(height + config.crane_gap, abs=1e-9)
    assert built.effects.crane.container == "load" and built.effects.crane.moves[0].kind == "hoist"
    # the hoist's trapezoid over 2 mm at 4 m/s^2 never reaches 0.2 m/s: sqrt(2 x 0.002 / 4) s = 31.6 ms
    assert config.landing_s() == pytest.approx(math.sqrt(2 * 0.002 / 4.0)) and config.landing_s() < config.big_duration


def test_models_come_from_the_engine_registry(monkeypatch):
    found = settings.models()
    assert set(SHIPPED) <= set(found)
    assert found["point"] == Candidate("drake", "point", label="Drake point")
    assert found["mujoco"].params == "matched" and found["mujoco_learned"].judged and found["learned"].judged

    class Novel(Engine):  # an engine registered tomorrow: in the study with no edit
        name, label, param_sets = "novel", "Novel", ("tuned", "plain")

    from testbed.engines import candidate, engine

    monkeypatch.setattr(settings, "engines", lambda: {**engines(), "novel": Novel()})
    monkeypatch.setattr(candidate, "engine", lambda name: Novel() if name == "novel" else engine(name))
    assert settings.models()["novel"] == Candidate("novel", "tuned", label="Novel (tuned)")
    scale.ScaleConfig(models=("novel",)).validate()


@pytest.mark.parametrize("change, option", [
    ({"sizes": (5,)}, "--sizes"), ({"sizes": ()}, "--sizes"), ({"sizes": (4, 4)}, "--sizes"),
    ({"sizes": (2000,)}, "--sizes"), ({"models": ("nonesuch",)}, "--models"), ({"duration": 0.0}, "--duration"),
    ({"big_duration": math.nan}, "--big-duration"), ({"settle_s": 0.0}, "--settle"), ({"tiers": 0}, "--tiers"),
    ({"repeats": 0}, "--repeats"), ({"passes": 0}, "--passes"), ({"yards": ("busy",)}, "--yards"),
    ({"caps": (("nonesuch", 4),)}, "--caps"), ({"clock": "sundial"}, "--clock"), ({"time_step": 0.5}, "--time-step")])
def test_bad_settings_are_one_line_errors_naming_the_option(change, option):
    with pytest.raises(scale.ScaleConfigError) as e:
        dataclasses.replace(TINY, **change).validate()
    assert str(e.value).startswith(option) and "\n" not in str(e.value)


def _row(n, model, us, status="ok", yard="settled", run=1):
    return {"n": n, "model": model, "us_per_step": us, "status": status, "yard": yard, "pass": run}


def test_growth_fit_is_the_log_log_slope_from_fit_from_up():
    rows = [_row(n, "point", 3.0 * n**1.5) for n in (16, 48, 96)] + [_row(4, "point", 1e6)]  # N=4 left out
    rows += [_row(192, "point", 1.0, status="diverged")]  # an incomplete run is not fitted
    rows += [_row(16, "mujoco", 5.0)]  # one size: no fit
    fits = scale.growth_fits(rows, ("point", "mujoco"), fit_from=16)
    assert fits["point"]["exponent"] == pytest.approx(1.5)
    assert fits["point"]["prefactor_us"] == pytest.approx(3.0)
    assert fits["point"]["sizes"] == [16, 48, 96]
    assert fits["point"]["stderr"] == pytest.approx(0.0, abs=1e-9)  # exact power law: no residual
    assert math.isnan(fits["mujoco"]["exponent"])


def test_a_known_exponent_is_recovered_from_noisy_synthetic_costs():
    """us = 40 N^0.85 x lognormal noise (sigma 0.05, seeded) at 96 ... 1000: the fitted exponent
    lies within 4 of its own standard errors of 0.85 (a 1e-4 chance of failing for a correct fit),
    and that standard error is the closed form sigma / sqrt(sum (log N - mean)^2) within a factor
    of 2 (8 points: the residual estimate of sigma is itself uncertain by ~25 %)."""
    rng = np.random.default_rng(7)
    sizes = np.array([96, 128, 192, 256, 384, 480, 720, 1000])
    us = 40.0 * sizes**0.85 * np.exp(rng.normal(0.0, 0.05, sizes.size))
    fit = scale.fit_exponent(sizes, us)
    closed = 0.05 / np.sqrt(np.sum((np.log(sizes) - np.log(sizes).mean()) ** 2))
    assert abs(fit["exponent"] - 0.85) < 4 * fit["stderr"]
    assert 0.5 * closed < fit["stderr"] < 2 * closed
    # one fit per pass and yard kind: pass 2 at twice the cost has the same exponent, pass 1's crane another
    rows = [_row(int(n), "mujoco_learned", float(u), yard="settled", run=1) for n, u in zip(sizes, us)]
    rows += [_row(int(n), "mujoco_learned", 2 * float(u), yard="settled", run=2) for n, u in zip(sizes, us)]
    rows += [_row(int(n), "mujoco_learned", float(n) ** 1.05, yard="crane", run=1) for n in sizes]
    fits = scale.pass_fits(rows, ("mujoco_learned",), 96, ("settled", "crane"), 2)
    assert fits["1"]["settled"]["mujoco_learned"]["exponent"] == pytest.approx(fit["exponent"], abs=1e-12)
    assert fits["2"]["settled"]["mujoco_learned"]["exponent"] == pytest.approx(fit["exponent"], abs=1e-12)
    assert fits["1"]["crane"]["mujoco_learned"]["exponent"] == pytest.approx(1.05, abs=1e-12)
    assert math.isnan(fits["2"]["crane"]["mujoco_learned"]["exponent"])  # no crane rows in pass 2


def test_the_timed_window_starts_after_the_settling_transient():
    """A cell settles its yard untimed for settle_s, then times duration from the settled state:
    the window's steps are its own (not the settling's), it starts at settle_s, from the poses
    and velocities the settling run ended with, and the stack has compressed under its weight."""
    config = dataclasses.replace(TINY, sizes=(4,), settle_s=0.03, duration=0.01, big_above=4, models=("point",))
    row = scale.run_cell(scale.tasks(config)[0])
    assert row["status"] == "ok", row
    assert row["window_start_s"] == pytest.approx(0.03) and row["simulated_s"] == pytest.approx(0.01)
    assert row["steps"] == 10  # 0.01 s at 1 ms: the settling's 30 steps are not in the timed figures
    settled = cells.settle(config, 4, "point")  # cached: the very run the window started from
    assert row["start_max_speed_mps"] == settled["max_speed_mps"] and row["start_kinetic_J"] == settled["kinetic_J"]
    assert 0 <= settled["kinetic_J"] <= settled["peak_kinetic_J"]
    start = scale.yard_scenario(4, config, "settled", state=settled["state"])
    i = settled["state"].names.index("blk_r1_b1_t4")
    top = next(c for c in start.containers if c.name == "blk_r1_b1_t4")
    assert np.allclose(top.pose().translation(), settled["state"].p_WB[i], atol=1e-12)
    assert np.allclose(top.V_WC, settled["state"].V_WB[i], atol=1e-12)
    # from rest the top sits exactly 3.5 heights up (faces touching); settled, the stack's contacts
    # are compressed by its weight: the top is lower, by less than the 5 mm penetration of the scene gates
    sag = 3.5 * CONTAINER_TYPES["1AA"].size[2] - settled["state"].p_WB[i][2]
    assert 0.0 < sag < 5e-3


def test_the_learned_loop_s_window_continues_its_settling_run_with_the_yard_asleep():
    """The MuJoCo-hosted learned loop's window continues its settling run (window.py): the
    sleeping islands (asleep after t_sleep = 0.3 s at rest) that fell asleep during the 0.8 s
    settle are asleep at the window's first step (a fresh run from the settled state restarts
    their rest timers: none asleep) and ask the predictor nothing while the settled yard rests;
    in the crane yard the load hangs still through the settling (its island asleep too) and
    its hoist, starting with the window, wakes its stack's island."""
    pytest.importorskip("mujoco")
    config = dataclasses.replace(TINY, sizes=(4,), settle_s=0.8, duration=0.01, models=("mujoco_learned",))
    settled, crane = (scale.run_cell(t) for t in scale.tasks(config))
    for row in (settled, crane):
        assert row["status"] == "ok", row
        assert row["window_start_s"] == pytest.approx(0.8) and row["steps"] == 10  # the settling's steps are not timed
        assert row["start_asleep_fraction"] >= 0.9 and row["start_islands_asleep"] == row["start_islands"] >= 1
        assert row["start_max_speed_mps"] < 1e-3 and row["start_kinetic_J"] < 1e-3 * row["settle_peak_kinetic_J"]
    assert settled["asleep_fraction"] >= 0.9 and settled["pairs_per_step"] == 0.0 and settled["reused_pairs_per_step"] == 3.0
    assert crane["pairs_per_step"] > 0  # the load moves: its island asks again
    # the load hung crane_gap above the stack's top from rest; the stack sagged under its weight meanwhile
    assert config.crane_gap < crane["start_load_clearance_m"] < config.crane_gap + 5e-3


def test_errors_are_against_the_reference_of_the_same_size_yard_and_pass():
    p = np.zeros((2, 3))
    q = np.tile([1.0, 0.0, 0.0, 0.0], (2, 1))
    base = {"status": "ok", "simulated_s": 0.1, "time_step_s": 1e-3, "q_final": q.tolist(), "yard": "settled", "pass": 1}
    rows = [{**base, "n": 4, "model": "hydroelastic", "p_final": p.tolist()},
            {**base, "n": 4, "model": "point", "p_final": (p + [[0.0, 0.0, 0.003], [0.004, 0.0, 0.0]]).tolist()},
            {**base, "n": 4, "model": "learned", "status": "diverged", "simulated_s": 0.05, "p_final": p.tolist()},
            {**base, "n": 8, "model": "point", "p_final": p.tolist()},  # no reference at N = 8
            {**base, "n": 4, "model": "point", "yard": "crane", "p_final": p.tolist()}]  # nor for the crane yard
    out = scale.with_errors(rows)
    assert out[0]["final_position_error_m"] == 0.0
    assert out[1]["final_position_error_m"] == pytest.approx(0.004)
    assert out[1]["final_angle_error_deg"] == pytest.approx(0.0, abs=1e-9)
    assert all(math.isnan(out[k]["final_position_error_m"]) for k in (2, 3, 4))
    assert all("p_final" not in r and "q_final" not in r for r in out)


def test_targets_read_the_study_s_figures():
    def row(n, model, rtf, yard="settled"):
        return {"n": n, "model": model, "status": "ok", "real_time_factor": rtf, "yard": yard, "pass": 1}

    fit = {"exponent": 0.95, "stderr": 0.02, "sizes": [96, 1000]}
    study = {"config": {"models": None, "yards": ("settled", "crane"), "clock": "wall"},
             "pass_fits": {"1": {"settled": {"mujoco_learned": fit}, "crane": {"mujoco_learned": {**fit, "exponent": 1.2}}},
                           "2": {"settled": {"mujoco_learned": {**fit, "exponent": 1.02}}, "crane": {}}},
             "rows": [row(1000, "mujoco_learned", 6.0), row(1000, "learned", 9.0), row(1000, "mujoco_learned", 0.8, "crane")]}
    out = {x["target"]: x for x in targets.targets(study)}
    growth = out["learned loop (in MuJoCo), settled yard: per-step growth exponent <= 1 in every pass"]
    assert growth["met"] is False and growth["measured"].startswith("0.95 +- 0.02 (N = 96-1000), 1.02")
    assert out["learned loop (in MuJoCo), settled yard: the passes' exponents within 0.1"]["met"] is True  # 0.07 apart
    assert out["learned loop (in MuJoCo), crane yard: per-step growth exponent <= 1.1 in every pass"]["met"] is False
    fast = out["learned loop (any host), settled yard of 1000: >= 5x real time (wall time)"]
    assert fast["met"] is True and fast["measured"] == "9.00x (learned loop (in Drake), its slowest pass)"  # the fastest host
    assert out["learned loop (any host), crane yard of 1000: >= 1x real time (wall time)"]["met"] is False
    # a host's speed counts in its slowest pass: 6x in pass 1 and 4x in pass 2 do not make 5x
    study["rows"] = [row(1000, "mujoco_learned", 6.0), {**row(1000, "mujoco_learned", 4.0), "pass": 2}]
    fast = {x["target"]: x for x in targets.targets(study)}["learned loop (any host), settled yard of 1000: >= 5x real time (wall time)"]
    assert fast["met"] is False and fast["measured"].startswith("4.00x")
    assert out["learned loop (in Drake), settled yard: per-step growth exponent <= 1 in every pass"]["met"] is None


def test_every_model_runs_a_tiny_yard_of_both_kinds(tiny_study):
    rows = tiny_study["rows"]
    names = TINY.model_names()
    assert set(SHIPPED) <= set(names)
    assert [(r["n"], r["model"], r["yard"]) for r in rows] == [(n, m, y) for n in TINY.sizes for m in names for y in TINY.yards]
    by = {(r["n"], r["model"], r["yard"]): r for r in rows}
    for n in TINY.sizes:
        for y in TINY.yards:
            for m in ("hydroelastic", "point", "learned"):
                assert by[n, m, y]["status"] == "ok", by[n, m, y]
            for m in set(names) - {"hydroelastic", "point", "learned"}:  # optional packages
                assert by[n, m, y]["status"] in ("ok", "unavailable"), by[n, m, y]
            assert by[n, "hydroelastic", y]["final_position_error_m"] == 0.0
    # the shorter windows above big_above, as the report says; every window after the settling
    assert by[4, "point", "settled"]["simulated_s"] == pytest.approx(0.01) and by[8, "point", "settled"]["simulated_s"] == pytest.approx(0.005)
    for r in rows:
        if r["status"] != "ok":
            continue
        assert r["window_start_s"] == pytest.approx(TINY.settle_s)
        assert r["steps"] == round(r["simulated_s"] / 1e-3) and r["us_per_step"] > 0
        assert r["real_time_factor"] == pytest.approx(r["simulated_s"] / r["wall_s"])
        # CPU time per step: the window's less the same build's and one step's; NaN only where that difference
        # drowned in the run-to-run spread of the builds (these windows are 5-10 steps)
        assert math.isnan(r["cpu_us_per_step"]) or r["cpu_real_time_factor"] == pytest.approx(1e3 / r["cpu_us_per_step"])
        split = r["split_us"]
        if settings.models()[r["model"]].judged:  # the learned loop's parts add up to its step
            assert sum(split.values()) == pytest.approx(r["us_per_step"], rel=1e-6)
            assert r["pairs_per_step"] > 0
        else:  # the engine's own contact is inside its step
            assert split == {"engine_step": r["us_per_step"], "learned_system": None, "predictor": None}
        if r["model"] != "hydroelastic" and r["yard"] == "settled":  # a settled yard: every model within a centimetre
            assert r["final_position_error_m"] < 0.01, r
    assert set(tiny_study["fits"]) == set(TINY.yards) and set(tiny_study["fits"]["settled"]) == set(names)
    json.dumps(tiny_study)  # JSON-able


def test_report_files_and_what_they_say(tiny_study, tmp_path):
    paths = scale.write_report(tiny_study, tmp_path / "out")
    names = {p.name for p in paths}
    assert names == {"scale.json", "scale.md", "scale.html", "scale_cost.png"}
    assert (tmp_path / "out" / "scale_cost.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    md = (tmp_path / "out" / "scale.md").read_text()
    assert "0.005 s at N = 8, SHORTER at the big sizes" in md and "SETTLES: 0.01 s simulated from rest, untimed" in md
    assert "x real time" in md and "Growth exponent" in md and "## Per size" in md
    for m in SHIPPED:
        assert settings.label(m) in md
    assert "<img src='data:image/png;base64," in (tmp_path / "out" / "scale.html").read_text()
    assert json.loads((tmp_path / "out" / "scale.json").read_text())["schema"] == scale.SCHEMA
    lines = scale.summary_lines(tiny_study)
    assert len(lines) == len(TINY.model_names()) * len(TINY.yards) and lines[0].startswith("Drake hydroelastic")


def test_an_engine_not_registered_reads_unavailable(monkeypatch):
    known = {k: v for k, v in engines().items() if k != "mujoco_learned"}
    monkeypatch.setattr(cells, "engines", lambda: known)
    config = dataclasses.replace(TINY, sizes=(4,), models=("mujoco_learned",), yards=("settled",))
    row = scale.run_cell(scale.tasks(config)[0])
    assert row["status"] == "unavailable" and "mujoco_learned" in row["why"]
    study = scale.run_study(config)
    assert math.isnan(study["fits"]["settled"]["mujoco_learned"]["exponent"])
    assert "no completed run" in scale.summary_lines(study)[0]


def test_a_model_above_its_cap_is_skipped():
    config = dataclasses.replace(TINY, sizes=(4, 8), models=("point",), yards=("settled",), caps=(("point", 4),))
    rows = [scale.run_cell(t) for t in scale.tasks(config)]
    assert rows[0]["status"] == "ok" and rows[1]["status"] == "skipped" and "cap of 4" in rows[1]["why"]


def test_cells_run_through_validates_local_executor():
    config = dataclasses.replace(TINY, sizes=(4,), models=("point", "mujoco"), yards=("settled",))
    study = scale.run_study(config, map_cells=functools.partial(map_calls, executor="local", workers=2), executor="local")
    assert [(r["n"], r["model"]) for r in study["rows"]] == [(4, "point"), (4, "mujoco")]
    assert study["rows"][0]["status"] == "ok" and study["executor"] == "local"


@pytest.mark.slow
def test_cells_run_through_ray():
    pytest.importorskip("ray")
    config = dataclasses.replace(TINY, sizes=(4,), models=("point",), yards=("settled",))
    study = scale.run_study(config, map_cells=functools.partial(map_calls, executor="ray"), executor="ray")
    assert study["rows"][0]["status"] == "ok"


@pytest.mark.parametrize("argv, message", [
    (["--sizes", "5"], "--sizes: expected multiples"), (["--sizes", "4,x"], "--sizes: expected comma-separated"),
    (["--models", "nonesuch"], "--models: unknown"), (["--quick", "--duration", "-1"], "--duration"),
    (["--caps", "point"], "--caps: expected MODEL=N"), (["--yards", "busy"], "--yards")])
def test_bad_flags_exit_2_with_one_line_and_write_nothing(argv, message, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["study", "scale", "--out", str(out), *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and "\n" not in err
    assert not out.exists()


def test_the_command_writes_the_report(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["study", "scale", "--quick", "--quiet", "--sizes", "4", "--models", "point,mujoco", "--settle", "0.005",
                 "--duration", "0.005", "--yards", "settled", "--out", str(out)]) == 0
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
    assert host["model"] in yard_budget.host_models() and host["n"] == 4
    assert host["host_step_s"] > 0 and host["learned_system_s"] >= 0 and host["pairs_per_step"] == pytest.approx(3.0)
