"""The ONNX contract of an exported predictor (what `testbed bench` and the ONNX predictor
source accept), and writing a graph to a file under it:
- inputs `p_AB` (n, 3), `R_AB` (n, 3, 3), `size_A` (n, 3), `size_B` (n, 3), float32:
  B's centre [m] and orientation in A's frame and both boxes' full extents [m]; the
  first axis is dynamic (symbolic name "n");
- outputs `point_A` (n, 3) [m] and `normal_A` (n, 3) (unit, from A into B), in A's
  frame as learned_contact.interface.Predictor.predict returns them, float32; the
  shipped exports add `depth` (n,) [m], the separating-axis penetration depth
  (negative = separated), as Predictor.depth returns it;
- metadata_props: `supported_sizes` (JSON list of [x, y, z] full extents [m]) and `name`.

Files are written to a temporary name beside the target and renamed on success. The onnx
package is imported on use (ONNX_PIN names the install command).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from learned_contact.errors import WeightsError
from learned_contact.export.onnx_blocks import IR_VERSION, OPSET

INPUTS = ("p_AB", "R_AB", "size_A", "size_B")
INPUT_SHAPES = {"p_AB": (3,), "R_AB": (3, 3), "size_A": (3,), "size_B": (3,)}
OUTPUTS = ("point_A", "normal_A", "depth")
BATCH = "n"
ONNX_PIN = "pip install onnx==1.23.1 onnxruntime==1.30.0"
TORCH_PIN = "pip install torch==2.13.0 onnxscript==0.7.2"


def require_onnx():
    """The onnx module; WeightsError naming the install command when it is missing."""
    try:
        import onnx
    except ImportError as exc:  # pragma: no cover - the test extra installs it
        raise WeightsError(f"exporting to ONNX needs the onnx package: {ONNX_PIN}") from exc
    return onnx


def model_proto(g, *, supported_sizes, name: str):
    """The ModelProto of Graph g with the contract's inputs, outputs and metadata."""
    onnx = require_onnx()
    from onnx import TensorProto, helper

    inputs = [helper.make_tensor_value_info(k, TensorProto.FLOAT, [BATCH, *INPUT_SHAPES[k]]) for k in INPUTS]
    outputs = [helper.make_tensor_value_info("point_A", TensorProto.FLOAT, [BATCH, 3]),
               helper.make_tensor_value_info("normal_A", TensorProto.FLOAT, [BATCH, 3]),
               helper.make_tensor_value_info("depth", TensorProto.FLOAT, [BATCH])]
    graph = helper.make_graph(g.nodes, name, inputs, outputs, g.initializers)
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", OPSET)],
                              producer_name="learned_contact.export.onnx_export")
    model.ir_version = IR_VERSION
    set_metadata(model, supported_sizes=supported_sizes, name=name)
    onnx.checker.check_model(model, full_check=True)
    return model


def set_metadata(model, *, supported_sizes, name: str) -> None:
    """Sets the contract's metadata_props (supported_sizes as JSON [[x, y, z], ...] [m], name)."""
    sizes = np.asarray(supported_sizes, dtype=float).reshape(-1, 3)
    props = {"supported_sizes": json.dumps(sizes.tolist()), "name": str(name)}
    keep = [(p.key, p.value) for p in model.metadata_props if p.key not in props]
    del model.metadata_props[:]
    for key, value in [*keep, *props.items()]:
        entry = model.metadata_props.add()
        entry.key, entry.value = key, value


def write_atomic(model, out_path) -> Path:
    """Saves a ModelProto to out_path via a temporary file beside it (renamed on success)."""
    out_path = Path(out_path)
    try:
        out_path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise WeightsError(f"cannot write ONNX file {out_path}: {exc.strerror or exc}") from exc
    tmp = out_path.with_name(f".{out_path.name}.{os.getpid()}.tmp")
    try:
        tmp.write_bytes(model.SerializeToString())
        os.replace(tmp, out_path)
    except OSError as exc:
        raise WeightsError(f"cannot write ONNX file {out_path}: {exc.strerror or exc}; expected a writable file "
                           "path") from exc
    finally:
        tmp.unlink(missing_ok=True)
    return out_path
