"""Loading an ONNX contact model (`.onnx`, run by onnxruntime on the CPU).

The contract (docs/bench.md):
- inputs `p_AB` (n, 3), `R_AB` (n, 3, 3), `size_A` (n, 3), `size_B` (n, 3): B's centre
  and orientation in A's frame and both boxes' full extents [m]; float32 or float64
  (the declared type is read and the inputs converted to it); the first axis dynamic;
- outputs `point_A` (n, 3) [m] in A and `normal_A` (n, 3) unit from A into B; optional
  `depth` (n,) [m] (negative: separated);
- optional metadata properties `supported_sizes` (JSON list of [x, y, z] full extents
  [m]; default: every container type the testbed simulates) and `name`.

`load_onnx(path)` checks the file before anything else uses it: a regular file under
MAX_MODEL_BYTES, a model onnxruntime accepts, the inputs and outputs named, typed and
shaped as above with a dynamic first axis, well-formed metadata, and a probe batch
(external.probe_poses) answered with finite, unit-normal outputs of the right shapes.
Every failure is one WeightsError line naming the file, the input or output and what was
expected. The session runs on one thread (intra- and inter-op), so its cost is compared
with the single-threaded native core on equal terms. Each run is bounded by
--model-call-timeout through the process's one watchdog thread (limits.onnx_deadline: no
thread per call); the predictor's `own_call` is session.run alone on a prepared feed, which
the bench times beside the full call.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from learned_contact.errors import PredictorOutputError, PredictorTimeoutError, WeightsError, onnx_file_error
from learned_contact.predictors import limits
from learned_contact.predictors.external import ExternalPredictor, consistency_probe, default_sizes
from testbed.safe_files import check_regular_file

INPUTS = {"p_AB": (3,), "R_AB": (3, 3), "size_A": (3,), "size_B": (3,)}  # name -> shape after the batch axis
OUTPUTS = {"point_A": (3,), "normal_A": (3,)}
OPTIONAL_OUTPUTS = {"depth": (), "force_n": (), "stiffness": (), "area": ()}
FORCE_OUTPUTS = ("force_n", "stiffness")  # a model's own force: both or neither (external.contact_force)
TYPES = {"tensor(float)": np.float32, "tensor(double)": np.float64}
# A contact model of the paper's size is a few kB, the shipped improved one ~60 kB; 256 MB
# admits any network a simulator would run per pair per step and refuses a runaway file.
MAX_MODEL_BYTES = 256 * 2**20
INSTALL = "pip install 'container-contact-testbed[onnx]' (onnx==1.23.1, onnxruntime==1.30.0)"
SUBGRAPH_ATTRIBUTES = ("g", "graphs")  # AttributeProto fields that hold subgraphs (Loop, If, Scan bodies)


def _graphs(graph):
    """The graph and every subgraph in it, depth first."""
    stack = [graph]
    while stack:
        g = stack.pop()
        yield g
        for node in g.node:
            for attribute in node.attribute:
                if attribute.HasField("g"):
                    stack.append(attribute.g)
                stack.extend(attribute.graphs)


def _tensors(graph):
    """Every TensorProto a graph holds as data: initializers and Constant-like attributes."""
    for g in _graphs(graph):
        yield from g.initializer
        for sparse in g.sparse_initializer:
            yield sparse.values
            yield sparse.indices
        for node in g.node:
            for attribute in node.attribute:
                if attribute.HasField("t"):
                    yield attribute.t
                yield from attribute.tensors


def check_graph(path: Path, file_bytes: int) -> None:
    """Refuses, before onnxruntime reads the file, a graph of more than max_nodes nodes
    (subgraphs counted) and a model whose file plus external data files exceed memory_bytes
    (external data named outside the model's folder is left to onnxruntime, which refuses it)."""
    try:
        import onnx
    except ImportError:
        raise WeightsError(f"ONNX model {path}: the onnx package is not installed; {INSTALL}") from None
    try:
        model = onnx.load_model(str(path), load_external_data=False)
    except Exception as exc:  # noqa: BLE001 - every unparsable file is the same error
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise WeightsError(f"ONNX model {path}: cannot parse it ({first[:200]}); expected an ONNX model file") from None
    bound = limits.limits()
    nodes = sum(len(g.node) for g in _graphs(model.graph))
    if nodes > bound.max_nodes:
        raise WeightsError(f"ONNX model {path}: has {nodes:,} nodes (subgraphs counted); expected at most "
                           f"{limits.bound_text('max_nodes')}")
    total, folder = file_bytes, path.resolve().parent
    for tensor in _tensors(model.graph):
        if tensor.data_location != onnx.TensorProto.EXTERNAL:
            continue
        entries = {e.key: e.value for e in tensor.external_data}
        target = (folder / entries.get("location", "")).resolve()
        try:
            length = int(entries["length"]) if "length" in entries else \
                max(0, os.stat(target).st_size - int(entries.get("offset", 0) or 0))
        except (OSError, ValueError):
            continue  # missing or unreadable: onnxruntime names it
        total += length
    if total > bound.memory_bytes:
        raise WeightsError(f"ONNX model {path}: its file and external data hold {total / 2**20:,.0f} MiB; expected "
                           f"at most {limits.bound_text('memory_bytes')}")



def _fail(path, what: str, problem: str, expected: str) -> WeightsError:
    return WeightsError(f"ONNX model {path}: {what} {problem}; expected {expected}")


def _session(path: Path):
    try:
        import onnxruntime as ort
    except ImportError:
        raise WeightsError(f"ONNX model {path}: onnxruntime is not installed; {INSTALL}") from None
    options = ort.SessionOptions()
    options.intra_op_num_threads = 1
    options.inter_op_num_threads = 1
    options.log_severity_level = 4  # fatal only: the loader and the calls report problems themselves
    ort.set_default_logger_severity(4)  # the same for onnxruntime's own logger (its coloured lines)
    try:
        return ort.InferenceSession(str(path), sess_options=options, providers=["CPUExecutionProvider"])
    except Exception as exc:  # noqa: BLE001 - every unreadable model is the same error
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise WeightsError(f"ONNX model {path}: onnxruntime cannot load it ({first[:200]}); expected an ONNX "
                           "model file (export one with torch.onnx.export or learned_contact.export.onnx_export)") from None


def _check_arg(path, kind: str, arg, tail: tuple) -> np.dtype:
    """The numpy dtype of one declared input/output, after checking type and shape."""
    if arg.type not in TYPES:
        raise _fail(path, f"{kind} {arg.name!r}", f"has type {arg.type}", "tensor(float) or tensor(double)")
    shape = list(arg.shape) if arg.shape is not None else None
    want = f"({', '.join(['n', *map(str, tail)])}) with a dynamic first axis n"
    if shape is None or len(shape) != 1 + len(tail):
        raise _fail(path, f"{kind} {arg.name!r}", f"has shape {shape}", want)
    if isinstance(shape[0], int) and not (kind == "output"):
        raise _fail(path, f"{kind} {arg.name!r}", f"has a static batch axis of {shape[0]}", want)
    for got, expected in zip(shape[1:], tail):
        if isinstance(got, int) and got != expected:
            raise _fail(path, f"{kind} {arg.name!r}", f"has shape {shape}", want)
    return TYPES[arg.type]


def _metadata(path, session) -> tuple[np.ndarray, str]:
    props = session.get_modelmeta().custom_metadata_map or {}
    name = props.get("name") or Path(path).stem
    if "supported_sizes" not in props:
        return default_sizes(), name
    try:
        sizes = np.asarray(json.loads(props["supported_sizes"]), dtype=float)
    except (ValueError, TypeError) as exc:
        raise _fail(path, "metadata 'supported_sizes'", f"is not a JSON list of numbers ({exc})",
                    "a JSON list of [x, y, z] full extents [m]") from None
    if sizes.ndim != 2 or sizes.shape[1] != 3 or len(sizes) == 0 or not np.all(np.isfinite(sizes)) \
            or np.any(sizes <= 0):
        raise _fail(path, "metadata 'supported_sizes'", f"has shape {sizes.shape}",
                    "a JSON list of [x, y, z] positive full extents [m]")
    return sizes, name


def check_file(path) -> None:
    """The checks that read no more than the file's graph: a regular file under
    MAX_MODEL_BYTES, nodes and external data within learned_contact.predictors.limits' bounds."""
    path = Path(path)
    size = check_regular_file(path, MAX_MODEL_BYTES, "ONNX model (.onnx)", onnx_file_error)
    check_graph(path, size)


def load_onnx(path) -> ExternalPredictor:
    """The ONNX model at `path` behind the Predictor interface (see the module docstring);
    WeightsError naming the file and what is wrong otherwise."""
    path = Path(path)
    check_file(path)
    session = _session(path)
    inputs = {a.name: a for a in session.get_inputs()}
    outputs = {a.name: a for a in session.get_outputs()}
    missing = [n for n in INPUTS if n not in inputs]
    extra = [n for n in inputs if n not in INPUTS]
    if missing or extra:
        raise _fail(path, "inputs", f"are {sorted(inputs)} (missing {missing}, unknown {extra})",
                    f"exactly {list(INPUTS)}")
    missing = [n for n in OUTPUTS if n not in outputs]
    if missing:
        raise _fail(path, "outputs", f"are {sorted(outputs)} (missing {missing})",
                    f"{list(OUTPUTS)} and optionally 'depth', 'force_n' with 'stiffness', 'area'")
    given = [n for n in FORCE_OUTPUTS if n in outputs]
    if len(given) == 1 or ("area" in outputs and not given):
        raise _fail(path, "outputs", f"are {sorted(outputs)} (a force needs both {list(FORCE_OUTPUTS)}, area with them)",
                    f"{list(FORCE_OUTPUTS)} together, or neither")
    dtypes = {n: _check_arg(path, "input", inputs[n], tail) for n, tail in INPUTS.items()}
    for n, tail in {**OUTPUTS, **{k: v for k, v in OPTIONAL_OUTPUTS.items() if k in outputs}}.items():
        _check_arg(path, "output", outputs[n], tail)
    wanted = list(OUTPUTS) + [n for n in ("depth",) if n in outputs]
    force_wanted = [n for n in ("force_n", "stiffness", "area") if n in outputs]
    sizes, name = _metadata(path, session)

    import onnxruntime as ort

    def prepared(p, R, sA, sB):
        return {n: np.ascontiguousarray(v, dtype=dtypes[n]) for n, v in
                (("p_AB", p), ("R_AB", R), ("size_A", sA), ("size_B", sB))}

    own_options = ort.RunOptions()  # the runs of own_call: bounded a round at a time (own_round)
    own_options.log_severity_level = 4

    def own_call(p, R, sA, sB):
        feed = prepared(p, R, sA, sB)
        return lambda: session.run(wanted, feed, own_options)

    def own_round(calls):
        return limits.onnx_deadline(own_options, f"ONNX model {path}", calls, f"{calls} of its own calls in a row")

    def answer(p, R, sA, sB):
        feed = prepared(p, R, sA, sB)
        run_options = ort.RunOptions()
        run_options.log_severity_level = 4
        try:
            with limits.onnx_deadline(run_options, f"ONNX model {path}"):
                result = session.run(wanted, feed, run_options)
        except PredictorTimeoutError:
            raise
        except Exception as exc:  # noqa: BLE001 - a model that fails at run time
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise PredictorOutputError(f"ONNX model {path}: failed on a batch of {len(p)} poses "
                                       f"({first[:200]})") from None
        return result[0], result[1], (result[2] if len(result) > 2 else None)

    def force(p, R, sA, sB):
        feed = prepared(p, R, sA, sB)
        run_options = ort.RunOptions()
        run_options.log_severity_level = 4
        try:
            with limits.onnx_deadline(run_options, f"ONNX model {path}"):
                result = session.run(force_wanted, feed, run_options)
        except PredictorTimeoutError:
            raise
        except Exception as exc:  # noqa: BLE001 - a model that fails at run time
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise PredictorOutputError(f"ONNX model {path}: its force failed on a batch of {len(p)} poses "
                                       f"({first[:200]})") from None
        return result[0], result[1], (result[2] if len(result) > 2 else None)

    depth_fn = (lambda p, R, sA, sB: answer(p, R, sA, sB)[2]) if "depth" in outputs else None
    predictor = ExternalPredictor(kind="onnx", name=name, answer=answer, supported_sizes=sizes, source=str(path),
                                  depth_fn=depth_fn, own_call=own_call, own_round=own_round,
                                  force_fn=force if force_wanted else None)
    probe(predictor)
    return predictor


def probe(predictor: ExternalPredictor) -> None:
    """The load-time probe (external.consistency_probe); turns any failure into one
    WeightsError line naming the source."""
    try:
        consistency_probe(predictor)
    except PredictorOutputError as exc:
        raise WeightsError(f"{exc} (on the load-time probe)") from None
    except WeightsError:
        raise
    except BaseException as exc:  # noqa: BLE001 - a user's model may raise anything, SystemExit included
        raise WeightsError(f"{predictor.source}: fails on the load-time probe ({type(exc).__name__}: "
                           f"{str(exc)[:200]}); expected point_A and normal_A (n, 3)") from None
