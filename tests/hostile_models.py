"""Hostile and broken contact models, for tests/learned/test_hostile_models.py and by hand.

ONNX files (the `*_onnx` makers write one into a directory and return its path) and Python
models for `module:attribute` (this module is importable as `hostile_models` when tests/ is
on sys.path). Each breaks the model contract or the bench's bounds in one way; every model
answers like the centre-line or geometric model otherwise, so that only the one fault is tested.
"""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

import numpy as np
from bench_models import CONTAINER_SIZES, GeometricModel

# ----------------------------------------------------------------------------- ONNX files


def _contract_onnx(path, extra_nodes=(), extra_inits=(), extra_outputs=(), point_input="point_raw", opset=18):
    """The centre-line model (point_A = p_AB / 2, normal_A = p_AB / |p_AB|, float32) with
    `extra_nodes` between the inputs and point_A: point_A = Identity(point_input)."""
    import onnx
    from onnx import TensorProto, helper

    f = TensorProto.FLOAT
    inputs = [helper.make_tensor_value_info(n, f, s) for n, s in
              (("p_AB", ["n", 3]), ("R_AB", ["n", 3, 3]), ("size_A", ["n", 3]), ("size_B", ["n", 3]))]
    inits = [helper.make_tensor("half", f, [], [0.5]), helper.make_tensor("axes", TensorProto.INT64, [1], [1]),
             *extra_inits]
    nodes = [helper.make_node("Mul", ["p_AB", "half"], ["point_raw"]),
             helper.make_node("ReduceL2", ["p_AB", "axes"], ["length"], keepdims=1),
             helper.make_node("Div", ["p_AB", "length"], ["normal_A"]),
             *extra_nodes,
             helper.make_node("Identity", [point_input], ["point_A"])]
    outputs = [helper.make_tensor_value_info("point_A", f, ["n", 3]), helper.make_tensor_value_info("normal_A", f, ["n", 3]),
               *extra_outputs]
    graph = helper.make_graph(nodes, "hostile", inputs, outputs, initializer=inits)
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", opset)])
    model.ir_version = 9
    helper.set_model_props(model, {"name": Path(path).stem, "supported_sizes": json.dumps(CONTAINER_SIZES)})
    path = Path(path)
    onnx.save(model, str(path))
    return path


def loop_forever_onnx(directory: Path, trips: int = 10**12) -> Path:
    """A Loop of `trips` iterations (a counter) whose result, times zero, is added to every
    point: the model is correct, and never answers."""
    from onnx import TensorProto, helper

    f = TensorProto.FLOAT
    body = helper.make_graph(
        [helper.make_node("Identity", ["cond_in"], ["cond_out"]), helper.make_node("Add", ["v_in", "one"], ["v_out"])],
        "body",
        [helper.make_tensor_value_info("i", TensorProto.INT64, []), helper.make_tensor_value_info("cond_in", TensorProto.BOOL, []),
         helper.make_tensor_value_info("v_in", f, [])],
        [helper.make_tensor_value_info("cond_out", TensorProto.BOOL, []), helper.make_tensor_value_info("v_out", f, [])],
        initializer=[helper.make_tensor("one", f, [], [1.0])])
    nodes = [helper.make_node("Loop", ["trips", "go", "v0"], ["v_end"], body=body),
             helper.make_node("Mul", ["v_end", "zero"], ["nothing"]),
             helper.make_node("Add", ["point_raw", "nothing"], ["point_looped"])]
    inits = [helper.make_tensor("trips", TensorProto.INT64, [], [trips]), helper.make_tensor("go", TensorProto.BOOL, [], [True]),
             helper.make_tensor("v0", f, [], [0.0]), helper.make_tensor("zero", f, [], [0.0])]
    return _contract_onnx(directory / "loop_forever.onnx", nodes, inits, point_input="point_looped")


def chained_onnx(directory: Path, nodes: int = 30_000) -> Path:
    """`nodes` Identity nodes in a chain before point_A: correct, and slow to load when long
    (250,000 of them took 42-55 s to load here)."""
    from onnx import helper

    chain = [helper.make_node("Identity", ["point_raw" if i == 0 else f"c{i - 1}"], [f"c{i}"]) for i in range(nodes)]
    return _contract_onnx(directory / "chained.onnx", chain, point_input=f"c{nodes - 1}")


def external_data_onnx(directory: Path, gib: float = 3.0) -> Path:
    """A ~600-byte .onnx whose initializer lives in an external file of `gib` GiB (sparse:
    it takes no disk), summed into point_A times zero."""
    from onnx import TensorProto, helper

    n = int(gib * 2**30) // 4
    data = directory / "weights.bin"
    with data.open("wb") as f:
        f.truncate(n * 4)
    big = TensorProto(name="big", data_type=TensorProto.FLOAT, dims=[n])
    big.data_location = TensorProto.EXTERNAL
    for key, value in (("location", data.name), ("offset", "0"), ("length", str(n * 4))):
        entry = big.external_data.add()
        entry.key, entry.value = key, value
    nodes = [helper.make_node("ReduceSum", ["big"], ["total"], keepdims=0),
             helper.make_node("Mul", ["total", "zero"], ["nothing"]),
             helper.make_node("Add", ["point_raw", "nothing"], ["point_big"])]
    inits = [big, helper.make_tensor("zero", TensorProto.FLOAT, [], [0.0])]
    return _contract_onnx(directory / "external.onnx", nodes, inits, point_input="point_big")


def npz_header_bomb(directory: Path) -> Path:
    """A weights .npz whose first network array's header claims 10^7 x 10^7 float64 (800 TB)
    but holds 32 bytes."""
    import io
    import zipfile

    header = np.lib.format.header_data_from_array_1_0(np.zeros(4))
    header["shape"] = (10**7, 10**7)
    member = io.BytesIO()
    np.lib.format.write_array_header_1_0(member, header)
    member.write(np.zeros(4).tobytes())
    path = directory / "header_bomb.npz"
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("mlp/W0.npy", member.getvalue())
    return path


ONNX_MAKERS = {"loop_forever": loop_forever_onnx, "chained": chained_onnx, "external_data": external_data_onnx}

# ----------------------------------------------------------------------------- Python models

HIGH = 3.0  # [m] B's centre this far above A's: never asked by the load-time probe (resting poses)


class _Geometric(GeometricModel):
    def geometric(self, p_AB, R_AB, size_A, size_B):
        point, normal = GeometricModel.predict(self, p_AB, R_AB, size_A=size_A, size_B=size_B)
        return np.array(point, dtype=float), np.array(normal, dtype=float)


class BatchMean(_Geometric):
    """Moves each point 5 % of the way towards the batch's mean centre: its answer depends on
    what else is in the batch."""

    def predict(self, p_AB, R_AB, *, size_A, size_B):
        point, normal = self.geometric(p_AB, R_AB, size_A, size_B)
        p = np.asarray(p_AB, dtype=float)
        return point + 0.05 * (p.mean(axis=0) - p), normal


class Noisy(_Geometric):
    """Adds uniform noise of +-5 cm to every point, new on every call."""

    def __init__(self):
        super().__init__()
        self._rng = np.random.default_rng()

    def predict(self, p_AB, R_AB, *, size_A, size_B):
        point, normal = self.geometric(p_AB, R_AB, size_A, size_B)
        return point + self._rng.uniform(-0.05, 0.05, point.shape), normal


class FarAway(_Geometric):
    """Answers points 1,000 km from both boxes."""

    def predict(self, p_AB, R_AB, *, size_A, size_B):
        point, normal = self.geometric(p_AB, R_AB, size_A, size_B)
        return point + np.array([1.0e6, 0.0, 0.0]), normal


class FailsAlone(_Geometric):
    """Raises on a batch of one pose (a model exported with a batch axis that must be > 1)."""

    def predict(self, p_AB, R_AB, *, size_A, size_B):
        if len(p_AB) == 1:
            raise ValueError("this model needs at least two poses per call")
        return self.geometric(p_AB, R_AB, size_A, size_B)


class HangsAlone(_Geometric):
    """Never answers a batch of one pose."""

    def predict(self, p_AB, R_AB, *, size_A, size_B):
        while len(p_AB) == 1:
            pass
        return self.geometric(p_AB, R_AB, size_A, size_B)


class HangsHigh(_Geometric):
    """Answers the load-time probe, and never answers a pose with B more than HIGH above A."""

    def predict(self, p_AB, R_AB, *, size_A, size_B):
        while np.any(np.asarray(p_AB)[:, 2] > HIGH):
            time.sleep(0.01)
        return self.geometric(p_AB, R_AB, size_A, size_B)


class Allocates(_Geometric):
    """Allocates (and touches) ALLOCATE_BYTES on every call."""

    ALLOCATE_BYTES = 3 * 2**30

    def predict(self, p_AB, R_AB, *, size_A, size_B):
        self._hoard = np.ones(self.ALLOCATE_BYTES // 8)
        return self.geometric(p_AB, R_AB, size_A, size_B)


class ManySizes(_Geometric):
    """Declares 3,000 supported sizes (the probe would ask 9 million pairs)."""

    supported_sizes = np.tile(np.array(CONTAINER_SIZES), (1000, 1)) + np.arange(3000)[:, None] * 1e-2


def exits():
    """A factory that exits the interpreter (SystemExit)."""
    sys.exit(0)


def interrupts():
    """A factory that raises KeyboardInterrupt."""
    raise KeyboardInterrupt


def aborts():
    """A factory that kills its process (SIGABRT, no message)."""
    os.abort()


HANGING_MODULE = '''"""Never finishes being imported."""
while True:
    pass
'''

MARKER_MODULE = '''"""Writes a marker file when imported: proof that code ran."""
from pathlib import Path
Path(__file__).with_name("MARKER").write_text("imported")


def make():
    raise RuntimeError("should never be called")
'''
