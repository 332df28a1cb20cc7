"""Hostile files: alias bombs, deep flow nesting, devices, FIFOs, directories,
duplicate keys and oversized files, given to every reader the testbed has (scenes, --set
values, calibration parameter files and toss data, --resume records). Each gives one line
naming the file and what was expected, exit 2 (TestbedError), nothing written, in under 2 s
and under 1 GiB."""

import json
import os
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import hostile_files
import numpy as np
import pytest
from test_bad_input import GOOD

from testbed import cli
from testbed.calibration import data as toss_data
from testbed.calibration.data import CalibrationDataError, load_tosses
from testbed.calibration.params_file import from_fragment
from testbed.errors import ScenarioError, TestbedError
from testbed.safe_files import InputFileError, load_json
from testbed.scenario import MAX_SCENE_BYTES, load_scenario
from testbed.validation.cases import Case
from testbed.validation.executors import case_path, load_record

ROOT = Path(__file__).resolve().parents[2]
# The bounds: the refusal itself (timed inside the child, after its imports) and the
# whole child's peak resident memory (pydrake's import alone is about 110 MB of it).
WALL_LIMIT_S = 2.0
RSS_LIMIT_KB = 1 << 20  # 1 GiB
# The child reports its own peak (VmHWM of its address space): wait4's ru_maxrss would carry the
# pytest parent's peak over the fork/vfork and exec (measured: a 1.2 GB parent gave 1212 MiB
# for a child whose VmHWM was 11 MB), failing the bound on a suite that grew large before.
_CHILD = ("import json, sys, time\nfrom testbed import cli\nt = time.perf_counter()\ncode = cli.main(sys.argv[1:])\n"
          "hwm = [int(l.split()[1]) for l in open('/proc/self/status') if l.startswith('VmHWM:')]\n"
          "print(json.dumps({'code': code, 'wall_s': time.perf_counter() - t, 'vm_hwm_kb': hwm[0] if hwm else None}))")


def _run_child(args, tmp_path, timeout_s=60.0):
    """Runs the CLI in a child process: (its JSON line, stderr text, peak RSS [KiB]); the child is
    killed after timeout_s (a hang fails the test instead of stalling it)."""
    out, err = tmp_path / "child.out", tmp_path / "child.err"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    with out.open("wb") as fo, err.open("wb") as fe:
        proc = subprocess.Popen([sys.executable, "-c", _CHILD, *args], stdout=fo, stderr=fe, stdin=subprocess.DEVNULL,
                                env=env, cwd=tmp_path)
        start = time.monotonic()
        while True:
            pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
            if pid:
                break
            if time.monotonic() - start > timeout_s:
                proc.kill()
                os.wait4(proc.pid, 0)
                pytest.fail(f"{args}: no answer after {timeout_s} s")
            time.sleep(0.02)
        proc.returncode = os.waitstatus_to_exitcode(status)
    lines = out.read_text().strip().splitlines()
    assert lines, f"the child printed nothing; stderr: {err.read_text()[-2000:]}"
    result = json.loads(lines[-1])
    return result, err.read_text(), result["vm_hwm_kb"] or usage.ru_maxrss  # no /proc: the bound is stricter


@pytest.mark.timing  # a wall bound on the refusal: alone on the machine (tests/tiers.py)
@pytest.mark.parametrize("kind", sorted(hostile_files.MAKERS))
def test_hostile_scene_exits_2_with_one_line_fast_and_small(kind, tmp_path):
    files = tmp_path / "files"
    files.mkdir()
    path = hostile_files.MAKERS[kind](files)
    out = tmp_path / "out"
    result, err, rss_kb = _run_child(["run", str(path), "--out", str(out), "--quiet"], tmp_path)
    assert result["code"] == 2, err
    assert err.count("\n") == 1 and err.startswith("testbed: error: "), err
    assert str(path) in err and "expected" in err, err
    assert result["wall_s"] < WALL_LIMIT_S, (kind, result)
    assert rss_kb < RSS_LIMIT_KB, (kind, rss_kb)
    assert not out.exists()


@pytest.mark.parametrize("kind, needle", [
    ("alias_bomb", "aliases expand"), ("deep_flow", "nested deeper"), ("duplicate_key", "'mass' twice"),
    ("oversized", "at most 256 KiB"), ("fifo", "FIFO"), ("directory", "directory"), ("dev_zero", "device"),
])
def test_each_hostile_scene_says_what_is_wrong(kind, needle, tmp_path):
    path = hostile_files.MAKERS[kind](tmp_path)
    with pytest.raises(ScenarioError, match=needle):
        load_scenario(path)


def test_the_size_limit_admits_a_scene_just_under_it(tmp_path):
    """256 KiB of comments and a valid scene loads (the limit refuses size, not content)."""
    scene = tmp_path / "padded.yaml"
    scene.write_text(GOOD + "#" * (MAX_SCENE_BYTES - len(GOOD) - 1) + "\n")
    assert scene.stat().st_size == MAX_SCENE_BYTES
    assert load_scenario(scene).containers[0].mass == 20000


def test_a_few_aliases_still_load():
    """Anchors a person would write (one contact block shared by two boxes) stay allowed."""
    text = GOOD.replace("  mass: 20000", "  mass: &m 20000") + "- {name: b, type: 1CC, mass: *m, X_WC: {translation: [0, 0, 3.9]}}\n"
    text = text.replace("effects:\n  contact: {}\n", "") + "effects:\n  contact: {}\n"
    scenario = load_scenario(text=text)
    assert [c.mass for c in scenario.containers] == [20000, 20000]


# ----------------------------------------------------------------------------- --set values


@pytest.mark.timing  # a wall bound on the refusal: alone on the machine (tests/tiers.py)
@pytest.mark.parametrize("value, needle", [
    ("[" * 1000 + "]" * 1000, "nested deeper"),
    ("&a [x, x, x, x, x, x, x, x, x, x]", None),  # an anchor alone is fine (then fails the schema: description is a string)
    ("{a: 1, a: 2}", "twice"),
    ("x" * 5000, "at most 4096"),
])
def test_hostile_set_values(value, needle, tmp_path):
    start = time.perf_counter()
    with pytest.raises(ScenarioError) as info:
        load_scenario(text=GOOD, overrides=[f"description={value}"])
    assert time.perf_counter() - start < WALL_LIMIT_S
    message = str(info.value)
    assert "\n" not in message and ("--set" in message or "description" in message), message
    if needle:
        assert needle in message, message


@pytest.mark.timing  # a wall bound on the refusal: alone on the machine (tests/tiers.py)
def test_set_alias_bomb_is_refused():
    anchors = ["&l0 [b]"] + [f"&l{i} [" + ", ".join([f"*l{i - 1}"] * 10) + "]" for i in range(1, 10)]
    start = time.perf_counter()
    with pytest.raises(ScenarioError, match="aliases expand"):
        load_scenario(text=GOOD, overrides=["description=[" + ", ".join(anchors) + "]"])
    assert time.perf_counter() - start < WALL_LIMIT_S


# ----------------------------------------------------------------------------- calibration files


def test_params_file_with_a_duplicate_key_is_refused(tmp_path):
    text = (ROOT / "testbed" / "calibration" / "cube_toss_point.yaml").read_text()
    bad = tmp_path / "params.yaml"
    bad.write_text(text.replace("duration: 1.0", "duration: 1.0\nduration: 2.0"))
    assert bad.read_text() != text
    with pytest.raises(ScenarioError, match="'duration' twice"):
        from_fragment(bad)


@pytest.mark.parametrize("kind, needle", [("fifo", "FIFO"), ("directory", "directory"), ("dev_zero", "device")])
def test_non_regular_toss_files_are_refused(kind, needle, tmp_path):
    path = hostile_files.MAKERS[kind](tmp_path)
    with pytest.raises(CalibrationDataError, match=needle):
        load_tosses(path)


@pytest.mark.timing  # a wall bound on the refusal: alone on the machine (tests/tiers.py)
def test_oversized_toss_file_is_refused_before_reading(tmp_path):
    path = tmp_path / "huge.npz"
    with path.open("wb") as f:  # sparse: no disk used
        f.truncate(toss_data.MAX_TOSS_FILE_BYTES + 1)
    start = time.perf_counter()
    with pytest.raises(CalibrationDataError, match="at most 128 MiB"):
        load_tosses(path)
    assert time.perf_counter() - start < WALL_LIMIT_S


def test_toss_file_whose_arrays_unpack_too_far_is_refused(tmp_path, monkeypatch):
    """A zip bomb is refused from the zip directory's sizes (shown with the limit lowered to
    1 MiB and 2 MiB of zeros, which compress to a few kilobytes)."""
    path = tmp_path / "bomb.npz"
    np.savez_compressed(path, states=np.zeros((2**21 // 8 // 13 + 1, 13)), offsets=np.array([0]), toss_id=np.array([0]), dt=np.array(0.01))
    assert path.stat().st_size < 100_000
    with zipfile.ZipFile(path) as z:
        assert sum(i.file_size for i in z.infolist()) > 2**21
    monkeypatch.setattr(toss_data, "MAX_TOSS_ARRAY_BYTES", 2**20)
    with pytest.raises(CalibrationDataError, match="unpack to 2 MiB"):
        load_tosses(path)


def test_calibrate_on_a_device_exits_2(tmp_path, capsys):
    code = cli.main(["calibrate", "evaluate", "--data", "/dev/zero", "--params",
                     str(ROOT / "testbed" / "calibration" / "cube_toss_point.yaml"), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "/dev/zero" in err and "device" in err, err
    assert not (tmp_path / "o").exists()


# ----------------------------------------------------------------------------- --resume records


def _run_dir_with_suite(tmp_path, text):
    run = tmp_path / "run"
    (run / "cases").mkdir(parents=True)
    (run / "suite.json").write_text(text)
    return run


@pytest.mark.timing  # a wall bound on the refusal: alone on the machine (tests/tiers.py)
@pytest.mark.parametrize("text, needle", [
    ('{"schema": 1, "schema": 2, "cases": []}', "'schema' twice"),
    ("[" * 100_000 + "]" * 100_000, "nested too deeply"),
    ('{"cases": 3}', "list of cases"),
    ('{"cases": [{"id": "a"}]}', "cases[0]"),
])
def test_resume_refuses_a_bad_suite_file(text, needle, tmp_path, capsys):
    run = _run_dir_with_suite(tmp_path, text)
    start = time.perf_counter()
    code = cli.main(["validate", "--resume", str(run), "--quiet"])
    err = capsys.readouterr().err
    assert time.perf_counter() - start < WALL_LIMIT_S
    assert code == 2 and err.count("\n") == 1 and "suite.json" in err and needle in err, err


@pytest.mark.parametrize("kind, needle", [("fifo", "FIFO"), ("directory", "directory")])
def test_resume_refuses_a_non_regular_suite_file(kind, needle, tmp_path, capsys):
    run = tmp_path / "run"
    run.mkdir()
    made = hostile_files.MAKERS[kind](run)
    made.rename(run / "suite.json")
    code = cli.main(["validate", "--resume", str(run), "--quiet"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and needle in err, err


def test_resume_refuses_an_oversized_suite_file(tmp_path):
    run = _run_dir_with_suite(tmp_path, "")
    with (run / "suite.json").open("wb") as f:
        f.truncate(65 * 2**20)  # sparse
    with pytest.raises(InputFileError, match="at most 64 MiB"):
        load_json(run / "suite.json", 64 * 2**20, "suite file")


def test_case_record_that_is_a_directory_is_refused_and_kept(tmp_path):
    case = Case(id="c1", kind="scene", params={})
    case_path(tmp_path, case.id).mkdir(parents=True)
    with pytest.raises(TestbedError, match="directory"):
        load_record(tmp_path, case)
    assert case_path(tmp_path, case.id).is_dir()


def test_case_record_with_a_duplicate_key_is_recomputed(tmp_path, capsys):
    case = Case(id="c1", kind="scene", params={})
    path = case_path(tmp_path, case.id)
    path.parent.mkdir(parents=True)
    path.write_text('{"id": "c1", "id": "c1", "kind": "scene", "params": {}, "status": "ok", "result": {}, "wall_s": 1}')
    assert load_record(tmp_path, case) is None
    assert "'id' twice" in capsys.readouterr().err and not path.exists()


@pytest.mark.parametrize("text", [
    GOOD.replace("duration: 0.01", "duration: 0.01\ndescription: &a [*a]"),
    GOOD.replace("effects:\n  contact: {}", "effects: &e\n  contact: {x: *e}"),
])
def test_self_referencing_alias_is_refused(text):
    """A node holding an alias to itself would be endless once written out for Drake's loader."""
    with pytest.raises(ScenarioError, match="refers to a node that contains it"):
        load_scenario(text=text)


def test_study_defaults_with_a_device_as_toss_data_exits_2_writing_nothing(tmp_path, capsys):
    out = tmp_path / "study"
    code = cli.main(["study", "defaults", "--toss-data", "/dev/zero", "--cases", "cube_tosses", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "/dev/zero" in err and "device" in err, err
    assert not out.exists()
