"""`testbed validate`: report files and schema, resume after a kill, Ray executor, exit status."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from testbed import cli
from testbed.validation import Case, is_timing_key, validate
from testbed.validation.suites import suite

SCHEMA = Path(__file__).resolve().parents[2] / "testbed" / "validation" / "report_schema.json"


def _deterministic(metrics: dict) -> dict:
    """metrics without the fields that measure time (they differ between any two runs)."""

    def strip(value):
        if isinstance(value, dict):
            return {k: strip(v) for k, v in value.items() if not is_timing_key(k)}
        if isinstance(value, list):
            return [strip(v) for v in value]
        return value

    return strip(metrics)


@pytest.fixture(scope="module")
def smoke_run(tmp_path_factory):
    run_dir, metrics = validate(suite_name="smoke", workers=1, out_root=tmp_path_factory.mktemp("reports"), progress=False)
    return run_dir, metrics


def test_report_files_and_schema(smoke_run):
    import jsonschema

    run_dir, metrics = smoke_run
    assert {"suite.json", "metrics.json", "summary.md", "index.html", "cases"} <= {p.name for p in run_dir.iterdir()}
    on_disk = json.loads((run_dir / "metrics.json").read_text())
    jsonschema.validate(on_disk, json.loads(SCHEMA.read_text()))
    assert set(on_disk["cases"]) == {c.id for c in suite("smoke")}
    assert all(case["status"] == "ok" for case in on_disk["cases"].values()), on_disk["cases"]
    html = (run_dir / "index.html").read_text()
    assert html.startswith("<!DOCTYPE html>") and "data:image/png;base64," in html and "<script src" not in html
    # the verdict is data: a healthy smoke suite passes every gate (a FAIL report also
    # prints "gates pass" in its counts line, so the text proves nothing)
    assert on_disk["passed"] is True, [g for g in on_disk["gates"] if not g["passed"]]
    assert on_disk["gates"] and all(g["passed"] for g in on_disk["gates"])
    names = " ".join(g["name"] for g in on_disk["gates"])
    assert "force balance" in names and "resting penetration" in names  # the rest gates are judged
    # Meshcat replays of the worst learned cases, linked from the report
    assert len(on_disk["replays"]) == 2 and all(v.endswith("replay.html") for v in on_disk["replays"].values())
    for link in on_disk["replays"].values():
        assert (run_dir / link).stat().st_size > 100_000 and link in html


def test_schema_rejects_a_broken_metrics_file(smoke_run):
    import jsonschema

    run_dir, _ = smoke_run
    broken = json.loads((run_dir / "metrics.json").read_text())
    del broken["gates"][0]["threshold"]
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(broken, json.loads(SCHEMA.read_text()))


def test_killed_run_resumes_to_the_same_report(smoke_run, tmp_path):
    _, reference = smoke_run
    out_root = tmp_path / "reports"
    command = [sys.executable, "-c",
               "import sys; from testbed.validation import validate; "
               f"validate(suite_name='smoke', workers=1, out_root={str(out_root)!r}, progress=False)"]
    process = subprocess.Popen(command, start_new_session=True)
    deadline = time.time() + 240
    cases_dir = None
    while time.time() < deadline:
        found = list(out_root.glob("*/cases/*.json")) if out_root.exists() else []
        if found:
            cases_dir = found[0].parent
            break
        time.sleep(0.2)
    os.killpg(process.pid, signal.SIGKILL)
    process.wait()
    assert cases_dir is not None, "no case finished within 240 s"
    done_before = {p.name for p in cases_dir.glob("*.json")}
    assert 0 < len(done_before) < len(suite("smoke")), "the kill must land mid-way"
    run_dir, resumed = validate(resume=cases_dir.parent, workers=1, progress=False)
    assert {p.name for p in cases_dir.glob("*.json")} >= done_before
    assert _deterministic(resumed) == _deterministic(reference)


def test_ray_executor_gives_the_same_results(smoke_run, tmp_path):
    pytest.importorskip("ray", reason="Ray is in the test extra: pip install -e '.[test]'")
    _, reference = smoke_run
    _, via_ray = validate(suite_name="smoke", executor="ray", out_root=tmp_path, progress=False)
    assert _deterministic(via_ray) == _deterministic(reference)


def test_failed_gate_gives_a_nonzero_exit(tmp_path, monkeypatch, capsys):
    from testbed.validation import suites as validate_module

    bad = [Case("scene-missing", "scene", {"scene": "no_such_scene", "model": "point", "duration": 0.01})]
    monkeypatch.setattr(validate_module, "suite", lambda name: bad)
    monkeypatch.chdir(tmp_path)
    code = cli.main(["validate", "--workers", "1", "--quiet"])
    out = capsys.readouterr().out
    assert code == 3
    assert "FAILED scene-missing: ran" in out


def test_bad_options_exit_2(tmp_path, capsys):
    assert cli.main(["validate", "--suite", "nope", "--quiet"]) == 2
    assert "expected one of: default, full, smoke" in capsys.readouterr().err
    assert cli.main(["validate", "--resume", str(tmp_path), "--quiet"]) == 2
    assert "no suite.json" in capsys.readouterr().err


def test_study_markdown_becomes_html_tables():
    from testbed.document import markdown_html

    out = markdown_html("# Title\n\nSome <text>\nmore.\n\n| a | b |\n|---|---:|\n| 1 | x<y |\n\n- item\n![chart](c.png)\n")
    assert "<h3>Title</h3>" in out and "<p>Some &lt;text&gt; more.</p>" in out
    assert "<table><tr><th>a</th><th>b</th></tr><tr><td>1</td><td>x&lt;y</td></tr></table>" in out
    assert "<li>item</li>" in out and "c.png" not in out


def test_a_real_gate_failure_exits_3_and_says_so_in_metrics(tmp_path, monkeypatch, capsys):
    """A scene stopped before it settles fails the force-balance gate (physics, not an
    error): the bridge's ground force after 0.05 s is not its weight. The CLI exits 3
    and metrics.json names exactly those gates as failed."""
    from testbed.validation import suites as validate_module

    unsettled = [Case("scene-bridge-point", "scene", {"scene": "bridge", "model": "point", "duration": 0.05})]
    monkeypatch.setattr(validate_module, "suite", lambda name: unsettled)
    code = cli.main(["validate", "--workers", "1", "--quiet", "--out", str(tmp_path)])
    capsys.readouterr()
    assert code == 3
    (run_dir,) = tmp_path.iterdir()
    metrics = json.loads((run_dir / "metrics.json").read_text())
    assert metrics["passed"] is False
    failed = [g["name"] for g in metrics["gates"] if not g["passed"]]
    assert failed == ["scene-bridge-point: force balance"], failed
    balance = next(g for g in metrics["gates"] if g["name"] == failed[0])
    assert abs(balance["value"] - 1.0) > 0.01  # the measured ratio really is off


def test_corrupt_case_file_is_recomputed_on_resume(smoke_run, tmp_path, capsys):
    """A truncated or corrupt case file under --resume is recomputed (and said so), not
    read as a result and not a traceback."""
    import shutil

    run_dir, reference = smoke_run
    copy = tmp_path / "run"
    shutil.copytree(run_dir, copy)
    for name in ("metrics.json", "summary.md", "index.html"):
        (copy / name).unlink()
    victims = sorted((copy / "cases").glob("scene-two_stack-*.json"))
    victims[0].write_text(victims[0].read_text()[:40])  # truncated mid-write
    victims[1].write_bytes(b"\x00\xff garbage")
    _, resumed = validate(resume=copy, workers=1, progress=False)
    err = capsys.readouterr().err
    assert victims[0].name.removesuffix(".json") in err and "recomput" in err
    assert _deterministic(resumed) == _deterministic(reference)


def test_in_scene_learned_gate_can_fail_and_pins_the_known_limit():
    """The in-scene gate judges the predictor where it is trained (hydroelastic-driven
    scenes): 1.3 cm passes, 5 cm fails; a known limit passes only inside its pinned band
    (worse or much better both fail); point-driven cases are not judged."""
    from testbed.validation.cases import registry

    kind = registry()["scene"]

    def gate(scene, model, median):
        record = {"id": f"scene-{scene}-{model}", "params": {"scene": scene, "model": model, "duration": None},
                  "result": {"learned_vs_hydro_point_error_median_m": median}}
        found = kind._in_scene_gates(record)
        return found[0].passed if found else None

    assert gate("five_stack", "hydroelastic", 0.013) is True
    assert gate("five_stack", "hydroelastic", 0.05) is False
    # no scene is pinned (two_stack 0.016 mm in scene): the plain bound holds there
    assert gate("two_stack", "hydroelastic", 0.0) is True and gate("two_stack", "hydroelastic", 0.032) is False
    # the pinning machinery, with a pin as two_stack had one (0.032 m, band 0.8-1.25x)
    from testbed.validation.cases import scene as scene_case

    with pytest.MonkeyPatch.context() as mp:
        mp.setitem(scene_case.KNOWN_IN_SCENE_LIMITS, "two_stack", ("a pinned figure", 0.032, (0.8, 1.25)))
        assert gate("two_stack", "hydroelastic", 0.032) is True
        assert gate("two_stack", "hydroelastic", 0.041) is False
        assert gate("two_stack", "hydroelastic", 0.02) is False  # stale pin
    assert gate("windy_stack", "hydroelastic", 0.009) is True and gate("windy_stack", "hydroelastic", 0.031) is False
    assert gate("five_stack", "point", 0.5) is None


def test_first_screen_counts_limits_and_candidates(smoke_run):
    """The verdict counts passes and pinned known limits apart (as metrics.json's gates say),
    lists every limit with its bound, and the summary table has a row per candidate the
    records measured; index.html has a table of contents and puts the limits first."""
    run_dir, _ = smoke_run
    on_disk = json.loads((run_dir / "metrics.json").read_text())
    gates = on_disk["gates"]
    pinned = [g for g in gates if g["passed"] and g["name"].endswith("(known limit)")]
    plain = [g for g in gates if g["passed"] and not g["name"].endswith("(known limit)")]
    assert on_disk["counts"] == {"passed": len(plain), "known_limits": len(pinned), "failed": 0}
    summary = (run_dir / "summary.md").read_text()
    verdict = summary.split("\n\n")[1]
    assert verdict.startswith("**PASS**: ")
    assert f"{len(plain)} gates pass, {len(pinned)} hold only within pinned known limits" in verdict
    # (the smoke suite has no pinned gate; the listing of limits is checked on a
    # synthetic one in test_the_first_screen_lists_each_known_limit_with_its_bound)
    for g in pinned:  # each limit: its figure in mm and the bound it does not meet
        assert f"- {g['name']}: {g['value'] * 1e3:.4g} mm against the {g['bound'] * 1e3:.4g} mm bound" in summary
        assert g["value"] > g["bound"]
    cases = on_disk["cases"].values()
    expected = {"Drake point contact"}  # the closed loop times it; the point scenes shadow hydroelastic
    expected |= {n for c in cases if c["kind"] == "closed_loop" for n in c["result"]["predictors"]}
    from testbed.engines import alternatives

    expected |= {f"{e.label} ({p})" for c in cases if c["kind"] == "engine" and c["result"].get("available")
                 for e in alternatives() for p in c["result"].get(e.name, {})}
    assert {"improved", "paper", "MuJoCo (matched)"} <= expected
    block = summary.split("## Summary: each candidate against Drake\n\n")[1].split("\n\n")[0]
    rows = [line.split(" | ")[0].lstrip("| ") for line in block.splitlines()[2:]]
    assert len(rows) == len(expected), rows
    assert all(sum(r == e or r.startswith(e + " (") for r in rows) == 1 for e in expected), (rows, expected)
    html = (run_dir / "index.html").read_text()
    assert "<nav class='toc'>" in html and "href='#summary-each-candidate-against-drake'" in html
    assert "<h2 id='summary-each-candidate-against-drake'>" in html
    if pinned:
        table_html = html.split("<h2 id='all-gates'>")[1]
        assert table_html.index(pinned[0]["name"]) < table_html.index(plain[0]["name"])


def test_the_first_screen_lists_each_known_limit_with_its_bound():
    """A pinned gate (synthetic: no shipped scene is pinned) is counted apart
    from the plain passes in the verdict and listed with its figure, the bound it misses and
    its band; without one the verdict says 0 and lists nothing."""
    from testbed.validation.summary import head_sections

    plain = {"name": "scene-five_stack-hydroelastic: learned point error in scene", "passed": True,
             "value": 0.001, "threshold": 0.03, "unit": "m"}
    pin = {"name": "scene-two_stack-hydroelastic: learned point error in scene (known limit)", "passed": True,
           "value": 0.032, "threshold": [0.0256, 0.04], "bound": 0.03, "unit": "m", "known_limit": True}

    def text(sections):
        return "\n".join(str(b) for s in sections for b in s.blocks)

    with_pin = head_sections({"gates": [plain, pin], "passed": True}, [])
    out = text(with_pin)
    assert "1 gates pass, 1 hold only within pinned known limits (listed below)." in out
    assert "32 mm against the 30 mm bound" in out and any(s.title == "Known limits" for s in with_pin)
    without = head_sections({"gates": [plain], "passed": True}, [])
    assert "1 gates pass, 0 hold only within pinned known limits." in text(without)
    assert not any(s.title == "Known limits" for s in without)
