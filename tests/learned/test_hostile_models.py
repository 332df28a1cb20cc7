"""Untrusted models and scene files: every hostile or broken model (tests/hostile_models.py)
is refused with one line naming it and what was expected, exit status 2, nothing written, in
bounded time and memory; a scene file never runs code.

Bounds used here: the model bounds are lowered (--model-load-timeout 4 s, --model-call-timeout
1 s, --model-memory 0.5 GiB) so that each hostile case ends in seconds; a CLI case must end
within WALL_LIMIT_S (the issue's 20 s, of which pydrake's import takes ~3 s) and the CLI
process's own peak resident memory stay under RSS_LIMIT_KB (the vetting child is bounded by
--model-memory and killed beyond it)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import bench_models as bm
import hostile_models as hm
import numpy as np
import pytest

from learned_contact import WeightsError, load_predictor
from learned_contact.errors import PredictorTimeoutError
from learned_contact.predictors import limits
from testbed.errors import ScenarioError
from testbed.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[2]
TESTS = ROOT / "tests"
WALL_LIMIT_S = 20.0
RSS_LIMIT_KB = 2 << 20  # 2 GiB
FAST = ["--model-load-timeout", "4", "--model-call-timeout", "1", "--model-memory", "0.5"]
SIZE_20 = np.array(bm.CONTAINER_SIZES[0])
_CHILD = ("import json, sys, time\nfrom testbed import cli\nt = time.perf_counter()\ncode = cli.main(sys.argv[1:])\n"
          "hwm = [int(l.split()[1]) for l in open('/proc/self/status') if l.startswith('VmHWM:')]\n"
          "print(json.dumps({'code': code, 'wall_s': time.perf_counter() - t, 'vm_hwm_kb': hwm[0] if hwm else 0}))")


@pytest.fixture
def bounded():
    """Lowered bounds for the in-process cases, restored afterwards."""
    before = limits.limits()
    limits.set_limits(load_timeout_s=4.0, call_timeout_s=1.0, memory_bytes=2**29)
    yield
    limits.set_limits(**{f: getattr(before, f) for f in limits.FLAGS})


def _cli(args, cwd: Path, timeout_s: float = 90.0):
    """(exit code, stderr, wall [s], peak RSS [KiB]) of `testbed ARGS` in a child process run in
    `cwd` with tests/ importable; the child is killed after timeout_s."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), str(TESTS)])}
    start = time.monotonic()
    proc = subprocess.run([sys.executable, "-c", _CHILD, *args], capture_output=True, text=True, env=env, cwd=cwd,
                          timeout=timeout_s, stdin=subprocess.DEVNULL)
    lines = proc.stdout.strip().splitlines()
    assert lines, f"no answer (exit {proc.returncode}); stderr: {proc.stderr[-2000:]}"
    result = json.loads(lines[-1])
    return result["code"], proc.stderr, time.monotonic() - start, result["vm_hwm_kb"]


def _compare(predictor: str, tmp_path: Path, *extra):
    out = tmp_path / "out"
    code, err, wall, rss = _cli(["compare", "two_stack", "--predictor", predictor, "--duration", "0.05", "--out", str(out),
                                 "--no-replay", *FAST, *extra], tmp_path)
    return code, err, wall, rss, out


def _one_line_exit_2(code, err, wall, rss, out, *needles):
    assert code == 2, err
    assert err.count("\n") == 1 and err.startswith("testbed: error: ") and "Traceback" not in err, err
    for needle in needles:
        assert needle in err, err
    assert wall < WALL_LIMIT_S, wall
    assert rss < RSS_LIMIT_KB, rss
    assert not out.exists()


# ----------------------------------------------------------------------------- scene files never run code

@pytest.mark.parametrize("effect", ["learned_dynamics", "learned_contact"])
@pytest.mark.parametrize("spec", ["evil_marker:make", "os:abort", "builtins:exit", "pdb:set_trace"])
def test_a_scene_file_naming_python_code_is_refused_without_running_it(spec, effect, tmp_path, monkeypatch):
    (tmp_path / "evil_marker.py").write_text(hm.MARKER_MODULE)
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    scene = tmp_path / "scene.yaml"
    scene.write_text((ROOT / "testbed/scenes/two_stack.yaml").read_text() + f"  {effect}: {{predictor: '{spec}'}}\n")
    with pytest.raises(ScenarioError, match="Python model") as info:
        load_scenario(scene)
    assert info.value.field == f"effects.{effect}.predictor" and str(scene) in str(info.value)
    assert not (tmp_path / "MARKER").exists() and "evil_marker" not in sys.modules


def test_a_scene_files_model_path_is_taken_from_the_scenes_folder(tmp_path, monkeypatch):
    folder = tmp_path / "scenes"
    folder.mkdir()
    bm.centre_line_onnx(folder / "mine.onnx")
    scene = folder / "scene.yaml"
    scene.write_text((ROOT / "testbed/scenes/two_stack.yaml").read_text() + "  learned_contact: {predictor: mine.onnx}\n")
    monkeypatch.chdir(tmp_path)  # not the scene's folder
    scenario = load_scenario(scene)
    assert scenario.effects.learned_contact.predictor == str((folder / "mine.onnx").resolve())


def test_the_cli_refuses_a_scene_naming_code_and_writes_nothing(tmp_path):
    (tmp_path / "evil_marker.py").write_text(hm.MARKER_MODULE)
    scene = tmp_path / "scene.yaml"
    scene.write_text((ROOT / "testbed/scenes/two_stack.yaml").read_text()
                     + "  learned_dynamics: {predictor: 'evil_marker:make'}\n")
    out = tmp_path / "out"
    code, err, wall, rss = _cli(["compare", str(scene), "--duration", "0.05", "--out", str(out), "--no-replay"], tmp_path)
    _one_line_exit_2(code, err, wall, rss, out, str(scene), "effects.learned_dynamics.predictor", "--predictor")
    assert not (tmp_path / "MARKER").exists()


# ----------------------------------------------------------------------------- what a user's code does when loaded

@pytest.mark.parametrize("spec, needle", [
    ("hostile_models:exits", "SystemExit"),
    ("hostile_models:interrupts", "KeyboardInterrupt"),
    ("hostile_models:aborts", "SIGABRT"),
    ("hostile_models:HangsAlone", "longer than 1 s (--model-call-timeout)"),
    ("hostile_models:FailsAlone", "at least two poses"),
    ("hostile_models:BatchMean", "asked alone"),
    ("hostile_models:Noisy", "asked again"),
    ("hostile_models:FarAway", "outside a box"),
    ("hostile_models:ManySizes", "3000 supported sizes"),
    ("hostile_models:Allocates", "0.5 GiB (--model-memory)"),
])
def test_a_hostile_python_model_is_refused_at_load(spec, needle, tmp_path):
    _one_line_exit_2(*_compare(spec, tmp_path), spec, needle)


@pytest.mark.parametrize("maker, needle", [
    ("loop_forever", "one call took longer than 1 s (--model-call-timeout)"),  # the probe's call, in the child
    ("chained", "30,001 nodes"),  # the chain and the point's Identity; the shared graph's 3 more: see below
    ("external_data", "3,072 MiB"),
])
def test_a_hostile_onnx_model_is_refused_at_load(maker, needle, tmp_path):
    files = tmp_path / "files"
    files.mkdir()
    path = hm.ONNX_MAKERS[maker](files)
    code, err, wall, rss, out = _compare(str(path), tmp_path)
    if maker == "chained":
        needle = "nodes (subgraphs counted); expected at most 20000"
    _one_line_exit_2(code, err, wall, rss, out, str(path), needle)
    assert err.count(str(path)) == 1, err  # named once, not once per layer of the error


def test_a_model_whose_import_never_ends_is_stopped_at_the_load_bound(tmp_path):
    (tmp_path / "slow_import.py").write_text(hm.HANGING_MODULE)
    _one_line_exit_2(*_compare("slow_import:make", tmp_path), "slow_import:make", "longer than 4 s (--model-load-timeout)")


def test_bench_and_compare_give_the_same_refusal(tmp_path):
    """A model failing only on one-pose calls: compare and the bench refuse it alike."""
    spec = "hostile_models:FailsAlone"
    compare = _compare(spec, tmp_path)
    out = tmp_path / "bench"
    code, err, wall, rss = _cli(["bench", spec, "--quick", "--out", str(out), *FAST], tmp_path)
    _one_line_exit_2(code, err, wall, rss, out, spec, "at least two poses")
    assert err.split(": ", 2)[2].strip() in compare[1]  # the same refusal, compare adding where it came from


def test_a_newline_in_a_model_file_name_cannot_forge_output(tmp_path):
    files = tmp_path / "files"
    files.mkdir()
    path = bm.centre_line_onnx(files / "x\nverdict: PASS\n.onnx", static_batch=2)
    code, err, wall, rss, out = _compare(str(path), tmp_path)
    _one_line_exit_2(code, err, wall, rss, out, "x\\nverdict: PASS\\n.onnx", "static batch axis")


def test_onnxruntime_prints_nothing_of_its_own(tmp_path):
    """The Loop stopped by its call bound: onnxruntime's own coloured error line is silenced."""
    path = hm.loop_forever_onnx(tmp_path, trips=10**12)
    code, err, wall, rss, out = _compare(str(path), tmp_path, "--model-load-timeout", "30")
    _one_line_exit_2(code, err, wall, rss, out, "one call took longer than 1 s (--model-call-timeout)")
    assert "\x1b[" not in err and "onnxruntime:" not in err


# ----------------------------------------------------------------------------- in process: calls, reuse, files

def test_a_call_that_hangs_after_loading_is_stopped_and_named(bounded):
    pred = load_predictor("hostile_models:HangsHigh")  # the probe asks resting poses only
    p = np.array([[0.0, 0.0, hm.HIGH + 0.5]])
    t0 = time.perf_counter()
    with pytest.raises(PredictorTimeoutError, match="hostile_models:HangsHigh: one call took longer than 1 s"):
        pred.predict(p, np.eye(3)[None], size_A=SIZE_20, size_B=SIZE_20)
    assert time.perf_counter() - t0 < 3.0
    point, _ = pred.predict(np.array([[0.0, 0.0, 2.5]]), np.eye(3)[None], size_A=SIZE_20, size_B=SIZE_20)
    assert np.all(np.isfinite(point))  # and it answers again afterwards


def test_an_onnx_call_that_loops_is_stopped_in_process(tmp_path, bounded):
    """The Loop model loaded without its child (as learned_contact.vet does): each run is
    stopped by onnxruntime's terminate flag at the call bound."""
    from learned_contact.predictors.onnx_model import load_onnx

    path = hm.loop_forever_onnx(tmp_path)
    t0 = time.perf_counter()
    with pytest.raises(WeightsError, match="one call took longer than 1 s"):
        load_onnx(path)
    assert time.perf_counter() - t0 < 3.0


def test_a_model_is_loaded_once_per_process(tmp_path):
    path = bm.centre_line_onnx(tmp_path / "m.onnx")
    first = load_predictor(str(path))
    assert load_predictor(str(path)) is first
    bm.centre_line_onnx(path, name="changed")  # a new file at the same path is loaded anew
    os.utime(path, ns=(time.time_ns(), time.time_ns() + 10**9))
    assert load_predictor(str(path)).name == "changed"


def test_an_npz_header_claiming_800_terabytes_is_one_line(tmp_path):
    path = hm.npz_header_bomb(tmp_path)
    with pytest.raises(WeightsError, match="claims a \\(10000000, 10000000\\) array") as info:
        load_predictor(str(path))
    assert str(path) in str(info.value) and "\n" not in str(info.value)


def test_a_correct_model_passes_the_consistency_probe():
    """The probe refuses what is wrong, not what is merely crude: the geometric model, the
    centre-line model and the shipped predictor behind the Python interface all pass."""
    assert load_predictor("bench_models:GeometricModel").kind == "python"
    assert load_predictor("bench_models:ShiftedModel").name == "shifted"


def test_limits_refuse_nonsense():
    with pytest.raises(WeightsError, match="--model-call-timeout"):
        limits.set_limits(call_timeout_s=-1)
    with pytest.raises(WeightsError, match="--model-memory"):
        limits.set_limits(memory_bytes=float("nan"))
