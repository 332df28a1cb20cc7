"""What the per-call bound on a user's model adds to each call, measured side by side.

    python -m learned_contact.evaluation.bound_cost [--calls 3000]

A tiny ONNX model (point_A = p_AB / 2, normal_A = p_AB / |p_AB|, float32: a few nodes, so
onnxruntime's own call is what remains) is run on the same prepared feed, for 1 and 96 pairs
per call, in turns within one loop (what the machine's load does to one it does to all):

- `session.run alone`: onnxruntime's call, no bound;
- `in the watchdog bound`: inside learned_contact.predictors.limits.onnx_deadline (the
  process's one watchdog thread, armed and disarmed per call);
- `in a Timer per call`: inside a threading.Timer started and cancelled per call, the bound
  as it was through 0.6.0, reproduced here for the comparison (in turns with session.run
  alone in a second loop: its short-lived threads slow whatever runs beside them);
- `answer function`: the loaded model's bounded call as the testbed makes it (input
  conversion, RunOptions, the bound);
- `full predict`: ExternalPredictor.predict (the testbed's input checks, the separating-axis
  depth, clipping).

And a Python model's call (a function returning its input) alone and inside
limits.python_deadline (SIGALRM armed per call). Prints the median and 90th percentile
[us per call] of each and the bound's median overhead [us]; the number of threads alive
before and after. Absolute times depend on the machine: read the differences within one run.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from learned_contact.predictors import limits
from learned_contact.predictors.onnx_model import _session, load_onnx

SIZE = (6.058, 2.438, 2.591)  # [m] a 20 ft container's full extents


def tiny_onnx(path: Path) -> Path:
    """Writes the tiny model of the module docstring to `path` (the testbed's ONNX contract)."""
    import onnx
    from onnx import TensorProto, helper

    f = TensorProto.FLOAT
    shapes = {"p_AB": ["n", 3], "R_AB": ["n", 3, 3], "size_A": ["n", 3], "size_B": ["n", 3]}
    graph = helper.make_graph(
        [helper.make_node("Mul", ["p_AB", "half"], ["point_A"]),
         helper.make_node("ReduceL2", ["p_AB", "axis"], ["norm"], keepdims=1),
         helper.make_node("Div", ["p_AB", "norm"], ["normal_A"])],
        "tiny", [helper.make_tensor_value_info(k, f, v) for k, v in shapes.items()],
        [helper.make_tensor_value_info("point_A", f, ["n", 3]), helper.make_tensor_value_info("normal_A", f, ["n", 3])],
        initializer=[helper.make_tensor("half", f, [], [0.5]), helper.make_tensor("axis", TensorProto.INT64, [1], [1])])
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 18)])
    model.ir_version = 9
    helper.set_model_props(model, {"name": "tiny", "supported_sizes": json.dumps([list(SIZE)])})
    onnx.save(model, str(path))
    return path


@contextlib.contextmanager
def timer_per_call(run_options, seconds: float):
    """The bound as it was through 0.6.0: a threading.Timer per call that sets terminate."""
    timer = threading.Timer(seconds, lambda: setattr(run_options, "terminate", True))
    timer.daemon = True
    timer.start()
    try:
        yield
    finally:
        timer.cancel()
        run_options.terminate = False


def side_by_side(fns: dict, calls: int) -> dict:
    """{name: (median, p90) [us per call]} of each function of no arguments, called in turns."""
    for fn in fns.values():
        for _ in range(50):
            fn()
    times = {name: [] for name in fns}
    for _ in range(calls):
        for name, fn in fns.items():
            t0 = time.perf_counter_ns()
            fn()
            times[name].append(time.perf_counter_ns() - t0)
    return {name: (float(np.median(t)) * 1e-3, float(np.percentile(t, 90)) * 1e-3) for name, t in times.items()}


def onnx_rows(session, predictor, n: int, calls: int) -> dict:
    """side_by_side of the ONNX rows of the module docstring, n pairs per call."""
    import onnxruntime as ort

    wanted, bound = ["point_A", "normal_A"], limits.limits().call_timeout_s
    p = np.tile([0.3, -0.2, SIZE[2] - 0.005], (n, 1))  # [m] B resting 5 mm deep on A, offset
    R = np.repeat(np.eye(3)[None], n, axis=0)
    s = np.tile(SIZE, (n, 1))
    feed = {k: np.ascontiguousarray(v, dtype=np.float32) for k, v in (("p_AB", p), ("R_AB", R), ("size_A", s),
                                                                        ("size_B", s))}
    options = ort.RunOptions()

    def watchdog():
        with limits.onnx_deadline(options, "tiny"):
            session.run(wanted, feed, options)

    def timer():
        with timer_per_call(options, bound):
            session.run(wanted, feed, options)

    def alone():
        session.run(wanted, feed, options)

    # the Timer's threads (each one wakes to end after its cancel) slow whatever runs beside
    # them: its rows are a second round of turns, with session.run alone again as their base
    return {**side_by_side({"session.run alone": alone, "in the watchdog bound": watchdog,
                            "answer function": lambda: predictor.answer_function(p, R, s, s),
                            "full predict": lambda: predictor.predict(p, R, size_A=s, size_B=s)}, calls),
            **{f"{k} (beside the Timer)" if k == "session.run alone" else k: v for k, v in
               side_by_side({"session.run alone": alone, "in a Timer per call (through 0.6.0)": timer}, calls).items()}}


def measure(calls: int = 3000) -> dict:
    """{'onnx': {pairs: {name: (median, p90) [us]}}, 'python': {1: {...}}, 'threads': (before,
    after)}: threads alive before the first bounded call and after them all."""
    threads_before = threading.active_count()
    with tempfile.TemporaryDirectory() as tmp:
        path = tiny_onnx(Path(tmp) / "tiny.onnx")
        predictor = load_onnx(path)
        session = _session(path)
    out = {"onnx": {n: onnx_rows(session, predictor, n, calls) for n in (1, 96)}}

    def model(x):
        return x

    def bounded():
        with limits.python_deadline("python"):
            model(1)

    out["python"] = {1: side_by_side({"model alone": lambda: model(1), "in the SIGALRM bound": bounded}, calls)}
    out["threads"] = (threads_before, threading.active_count())
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=int, default=3000, help="calls of each function (default 3000)")
    args = parser.parse_args(argv)
    out = measure(args.calls)
    for kind, alone in (("onnx", "session.run alone"), ("python", "model alone")):
        for n, rows in out[kind].items():
            print(f"{kind}, {n} pair{'s' if n > 1 else ''} per call [us per call]: median, p90, median over alone")
            for name, (median, p90) in rows.items():
                base = rows[f"{alone} (beside the Timer)" if "Timer" in name else alone][0]
                print(f"  {name:42s} {median:9.1f} {p90:9.1f} {median - base:+9.1f}")
    print(f"threads alive: {out['threads'][0]} before, {out['threads'][1]} after (the watchdog: one per process)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
