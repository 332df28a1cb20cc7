"""The per-call bounds on a user's model without a thread per call, and bounds that never count
the testbed's own work.

- ONNX: one watchdog thread per process stops a run past --model-call-timeout through
  onnxruntime's terminate flag; a fast run is not stopped; 200 calls start no thread (through
  0.6.0 each started a threading.Timer); a lowered bound is obeyed at once; a forked child
  has its own watchdog; a round of runs (the bench timing a model's own calls) is bounded as a
  whole, and a model's own calls never run unbounded.
- Python: SIGALRM stops a model that sleeps in its call; the handler in place before is back
  after each call.
- The testbed's own work (limits.project_work: loading and warming the shipped predictor) is not
  counted, in this process and in the vetting child, whose clock also starts only after its own
  start-up; the model's own slowness still is.

Bounds here are fractions of a second against sleeps of slow_models.SLEEP_S (2 s); no test
asserts a wall time of its own, only which bound stopped a call.
"""

from __future__ import annotations

import multiprocessing
import signal
import threading
import time

import bench_models as bm
import hostile_models as hm
import numpy as np
import pytest
import slow_models as sm

from learned_contact import WeightsError, load_predictor, sources
from learned_contact.errors import PredictorTimeoutError
from learned_contact.predictors import limits

SIZE = np.array(bm.CONTAINER_SIZES[0])  # [m]


def _pose(n: int = 1):
    """n poses of B resting on A (20 ft boxes): (p (n, 3) [m], R (n, 3, 3), size_A, size_B (n, 3) [m])."""
    p = np.tile([0.2, -0.1, SIZE[2] - 0.004], (n, 1))
    return p, np.repeat(np.eye(3)[None], n, axis=0), np.tile(SIZE, (n, 1)), np.tile(SIZE, (n, 1))


@pytest.fixture
def bounds():
    """Sets bounds for one test (limits.set_limits keywords) and restores those before it."""
    before = limits.limits()
    yield lambda **changes: limits.set_limits(**changes)
    limits.set_limits(**{f: getattr(before, f) for f in limits.FLAGS})


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    pytest.importorskip("onnxruntime", reason="pip install onnxruntime==1.30.0")
    return bm.centre_line_onnx(tmp_path_factory.mktemp("tiny") / "tiny.onnx")


def _looping_session(directory):
    """(session, feed) of hostile_models' Loop model (10^12 trips: it never answers on its own)."""
    pytest.importorskip("onnxruntime", reason="pip install onnxruntime==1.30.0")
    from learned_contact.predictors.onnx_model import _session

    p, R, sA, sB = _pose()
    feed = {"p_AB": p, "R_AB": R, "size_A": sA, "size_B": sB}
    return _session(hm.loop_forever_onnx(directory)), {k: v.astype(np.float32) for k, v in feed.items()}


def _bounded_run(session, feed, source="looping model"):
    import onnxruntime as ort

    options = ort.RunOptions()
    with limits.onnx_deadline(options, source):
        return session.run(["point_A", "normal_A"], feed, options)


# ----------------------------------------------------------------------------- ONNX: the watchdog

def test_the_watchdog_stops_an_onnx_run_and_lets_fast_ones_answer(tmp_path, tiny, bounds):
    from learned_contact.predictors.onnx_model import load_onnx

    bounds(call_timeout_s=0.3)
    session, feed = _looping_session(tmp_path)
    with pytest.raises(PredictorTimeoutError, match=r"^looping model: one call took longer than 0.3 s "
                                                    r"\(--model-call-timeout\) and was stopped"):
        _bounded_run(session, feed)  # 10^12 trips: only the terminate flag ends it
    assert limits.watchdog_thread() is not None and limits.watchdog_thread().is_alive()
    pred = load_onnx(tiny)  # fast calls under the same bound answer, and answer right
    for n in (1, 96):
        p, R, sA, sB = _pose(n)
        point, normal = pred.predict(p, R, size_A=sA, size_B=sB)
        want_point, want_normal = bm.centre_line_numpy(p)
        assert np.allclose(point, want_point, atol=1e-5) and np.allclose(normal, want_normal, atol=1e-5)
    with pytest.raises(PredictorTimeoutError):  # and the watchdog still stops the next slow one
        _bounded_run(session, feed)


def test_two_hundred_calls_start_no_thread(tiny, monkeypatch):
    """The watchdog is started once per process; a call only arms and disarms it."""
    from learned_contact.predictors.onnx_model import load_onnx

    pred = load_onnx(tiny)
    p, R, sA, sB = _pose()
    pred.predict(p, R, size_A=sA, size_B=sB)  # the watchdog exists from here on
    watchdog, alive = limits.watchdog_thread(), threading.active_count()
    started = []
    real_start = threading.Thread.start
    monkeypatch.setattr(threading.Thread, "start", lambda self: (started.append(self.name), real_start(self))[1])
    for _ in range(200):
        pred.predict(p, R, size_A=sA, size_B=sB)
    assert started == []  # a threading.Timer per call (through 0.6.0) started 200
    assert threading.active_count() == alive and limits.watchdog_thread() is watchdog
    names = [t.name for t in threading.enumerate()]
    assert names.count("testbed-model-watchdog") == 1


def test_a_lowered_bound_wakes_the_sleeping_watchdog(tmp_path, tiny, bounds):
    """A call under a 60 s bound sends the watchdog to sleep until its deadline; a call armed
    after the bound is lowered to 0.3 s is stopped by the lower bound, not at the first's."""
    from learned_contact.predictors.onnx_model import load_onnx

    bounds(call_timeout_s=60.0)
    pred = load_onnx(tiny)
    p, R, sA, sB = _pose()
    pred.predict(p, R, size_A=sA, size_B=sB)
    session, feed = _looping_session(tmp_path)
    bounds(call_timeout_s=0.3)
    t0 = time.monotonic()
    with pytest.raises(PredictorTimeoutError, match="longer than 0.3 s"):
        _bounded_run(session, feed)
    assert time.monotonic() - t0 < 60.0  # stopped by the lowered bound, before the first call's deadline


def _child_stops_a_looping_run(directory: str) -> None:
    from pathlib import Path

    limits.set_limits(call_timeout_s=0.3)
    session, feed = _looping_session(Path(directory))
    try:
        _bounded_run(session, feed)
    except PredictorTimeoutError:
        raise SystemExit(7) from None
    raise SystemExit(1)


def test_a_forked_child_has_its_own_watchdog(tmp_path, tiny):
    """The parent's watchdog thread does not exist in a fork (validate's process pool forks):
    the child starts its own on its first bounded call."""
    from learned_contact.predictors.onnx_model import load_onnx

    pred = load_onnx(tiny)
    p, R, sA, sB = _pose()
    pred.predict(p, R, size_A=sA, size_B=sB)
    assert limits.watchdog_thread() is not None  # started here before the fork
    child = multiprocessing.get_context("fork").Process(target=_child_stops_a_looping_run, args=(str(tmp_path),))
    child.start()
    child.join(120)
    if child.is_alive():
        child.kill()
        child.join()
    assert child.exitcode == 7  # its looping run was stopped (1: it ended otherwise; None or -9: never)


def test_a_round_of_runs_is_bounded_as_a_whole(tmp_path, bounds):
    """The bench's timing of a model's own calls arms one bound over a round of them
    (calls x --model-call-timeout) instead of one per call; a looping run is still stopped."""
    import onnxruntime as ort

    bounds(call_timeout_s=0.2)
    session, feed = _looping_session(tmp_path)
    options = ort.RunOptions()
    with pytest.raises(PredictorTimeoutError, match=r"^looping model: 3 runs in a row took longer than 0.6 s "
                                                    r"\(3 x --model-call-timeout\) and was stopped"):
        with limits.onnx_deadline(options, "looping model", calls=3, what="3 runs in a row"):
            for _ in range(3):
                session.run(["point_A", "normal_A"], feed, options)


def test_a_models_own_calls_are_never_unbounded(bounds):
    """ExternalPredictor.own_call runs the model alone (what the bench times); inside own_round
    a Python model that hangs there is stopped and named, and its answer is the model's own."""
    bounds(call_timeout_s=0.3)
    pred = load_predictor("hostile_models:HangsHigh")  # answers the probe; hangs with B high above A
    p, R, sA, sB = _pose(2)
    with pred.own_round(1):
        point, _ = pred.own_call(p, R, sA, sB)()
    assert np.allclose(point, pred.predict(p, R, size_A=sA, size_B=sB)[0])
    fine, high = pred.own_call(p, R, sA, sB), pred.own_call(p + [0.0, 0.0, hm.HIGH + 1.0], R, sA, sB)
    with pytest.raises(PredictorTimeoutError, match=r"hostile_models:HangsHigh: 2 of its own calls in a row took "
                                                    r"longer than 0.6 s \(2 x --model-call-timeout\)"):
        with pred.own_round(2):
            fine()
            high()  # never answers alone


# ----------------------------------------------------------------------------- Python: SIGALRM

def test_a_python_model_that_sleeps_in_its_call_is_stopped(bounds):
    from learned_contact.predictors.python_model import load_python

    bounds(call_timeout_s=0.3)
    before = signal.getsignal(signal.SIGALRM)
    with pytest.raises(WeightsError, match=r"slow_models:SleepsInCall: one call took longer than 0.3 s "
                                           r"\(--model-call-timeout\) and was stopped.*\(on the load-time probe\)"):
        load_python("slow_models:SleepsInCall")
    assert signal.getsignal(signal.SIGALRM) == before  # the handler in place before is back
    fast = load_python("slow_models:CentreLine")
    p, R, sA, sB = _pose(3)
    point, _ = fast.predict(p, R, size_A=sA, size_B=sB)
    assert np.allclose(point, 0.5 * p) and signal.getsignal(signal.SIGALRM) == before


def test_project_work_pauses_the_python_bound_and_resumes_it(bounds):
    bounds(call_timeout_s=0.3)
    with limits.python_deadline("paused"):
        with limits.project_work():
            time.sleep(0.6)  # twice the bound, as the testbed's own work: not counted
    with pytest.raises(PredictorTimeoutError, match="resumed: one call took longer than 0.3 s"):
        with limits.python_deadline("resumed"):
            with limits.project_work():
                time.sleep(0.6)
            time.sleep(5.0)  # the model's own: stopped by what is left of its bound


# ----------------------------------------------------------------------------- the testbed's own work

class _SlowToStart:
    """The shipped predictor as a cold start makes it: its first answer waits `delay_s` (a
    kernel compilation) before answering."""

    def __init__(self, inner, delay_s: float):
        self._inner, self._delay = inner, delay_s
        self.supported_sizes = inner.supported_sizes

    def predict(self, *args, **kwargs):
        time.sleep(self._delay)
        self._delay = 0.0
        return self._inner.predict(*args, **kwargs)

    def depth(self, *args, **kwargs):
        return self._inner.depth(*args, **kwargs)


@pytest.fixture
def slow_shipped(monkeypatch):
    """Loading a shipped predictor takes 1.5 s and its first answer 1.5 s more, in a fresh cache."""
    real = sources.load_weights

    def slow(spec, compiled=True):
        time.sleep(1.5)
        return _SlowToStart(real(spec, compiled=compiled), 1.5)

    monkeypatch.setattr(sources, "load_weights", slow)
    monkeypatch.setattr(sources, "_loaded", {})


def test_the_sensitivity_model_is_not_charged_for_the_shipped_predictors_start(bounds, slow_shipped):
    """testbed.validation.sensitivity:bias_5cm wraps the shipped predictor: its factory loads it
    (1.5 s here, under a 0.5 s load bound) and its first call would compile it (1.5 s, under a
    0.5 s call bound). Both are the testbed's own work: the model loads and answers. Through
    0.6.0 this was refused ('one call took longer than ... (on the load-time probe)')."""
    bounds(load_timeout_s=0.5, call_timeout_s=0.5)
    pred = sources.load_unvetted("testbed.validation.sensitivity:bias_5cm")
    p, R, sA, sB = _pose(2)
    point, _ = pred.predict(p, R, size_A=sA, size_B=sB)
    shipped, _ = load_predictor("improved").predict(p, R, size_A=sA, size_B=sB)
    assert np.allclose(point - shipped, [0.05, 0.0, 0.0])


def test_a_model_that_loads_the_shipped_predictor_and_then_sleeps_is_still_stopped(bounds, slow_shipped):
    bounds(load_timeout_s=0.5, call_timeout_s=0.5)
    with pytest.raises(WeightsError, match=r"slow_models:ShippedThenSleeps: one call took longer than 0.5 s"):
        sources.load_unvetted("slow_models:ShippedThenSleeps")


def test_the_vetting_clock_counts_the_model_not_the_testbed(bounds, tmp_path, monkeypatch):
    """In the vetting child: the testbed's own work while the model loads (2 s) is not counted
    against a 1 s load bound, nor is a slow interpreter start-up (2 s, before the testbed's
    imports are done); a factory that itself takes 2 s is refused at that bound."""
    bounds(load_timeout_s=1.0, call_timeout_s=1.0)
    limits.vet_in_child("slow_models:own_work_then_model")  # accepted: no exception
    with pytest.raises(WeightsError, match=r"slow_models:slow_factory.*longer than 1 s \(--model-load-timeout\)"):
        limits.vet_in_child("slow_models:slow_factory")
    (tmp_path / "sitecustomize.py").write_text(sm.SLOW_START_UP)
    monkeypatch.syspath_prepend(str(tmp_path))  # the child's PYTHONPATH is this process's sys.path
    limits.vet_in_child("slow_models:CentreLine")


def test_the_testbeds_own_time_in_the_vetting_child_has_its_own_cap(bounds, monkeypatch):
    bounds(load_timeout_s=1.0)
    monkeypatch.setattr(limits, "PROJECT_WORK_S", 0.5)
    with pytest.raises(WeightsError, match=r"refused: the testbed's own start-up and kernels .* longer than 0.5 s"):
        limits.vet_in_child("slow_models:own_work_then_model")
