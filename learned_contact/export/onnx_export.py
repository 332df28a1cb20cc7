"""Exporting predictors to ONNX with the bench's contract, for a simulator to run.

    from learned_contact.export.onnx_export import export_onnx, export_torch_model
    export_onnx("improved", "improved.onnx")          # or "paper", or a weights .npz
    export_torch_model(module, "my_model.onnx", supported_sizes=[[6.058, 2.438, 2.591]], name="mine")

Both write a file under the contract of onnx_contract.py (inputs p_AB, R_AB, size_A, size_B;
outputs point_A, normal_A and, for the shipped exports, depth; metadata supported_sizes and
name). The package, by concept:
- onnx_contract.py: the contract, the model's metadata, the atomic file write;
- onnx_predictors.py: the shipped predictors' graphs ("improved", "paper") and what they hold;
- onnx_blocks.py, onnx_prior.py, onnx_quadrature.py, onnx_network.py: the graphs' building
  blocks, the geometric prior's, the face-on-face quadrature's and the network's graphs;
- onnx_check.py: probe poses, an onnxruntime session, the agreement with the compiled path.

Importing this module imports neither onnx nor torch (they are imported on use).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from learned_contact.errors import WeightsError
from learned_contact.export.onnx_contract import BATCH, INPUTS, TORCH_PIN, model_proto, require_onnx, set_metadata, write_atomic
from learned_contact.export.onnx_predictors import improved_graph, paper_graph
from learned_contact.predictors.loading import load_weights


def export_onnx(name_or_path, out_path, *, name=None) -> Path:
    """Exports a shipped predictor ("improved", "paper") or a weights .npz (as
    learned_contact.predictors.loading.load_weights accepts) to an ONNX file with the contract above.
    name: the metadata `name` (default: the predictor's name or the file's stem).
    Returns the path written. Raises WeightsError (one line naming the file) for a
    name or path that does not load."""

    predictor = load_weights(name_or_path, compiled=False)
    if name is None:
        name = name_or_path if isinstance(name_or_path, str) and not str(name_or_path).endswith(".npz") \
            else Path(name_or_path).stem
    graph = improved_graph(predictor) if predictor.kind == "improved" else paper_graph(predictor)
    return write_atomic(model_proto(graph, supported_sizes=predictor.supported_sizes, name=str(name)), out_path)


def export_torch_model(module, out_path, *, supported_sizes, name: str) -> Path:
    """Exports a torch.nn.Module whose forward is (p_AB (n, 3), R_AB (n, 3, 3), size_A
    (n, 3), size_B (n, 3)) -> (point_A (n, 3) [m], normal_A (n, 3) unit A->B), all in
    A's frame, float32, to the ONNX contract: torch.onnx.export (the torch.export-based
    exporter, opset 18) with the contract's input and output names and one dynamic
    first axis "n", then the metadata (supported_sizes (k, 3) full extents [m], name)
    added with the onnx package. Written via a temporary file; returns the path. Needs
    torch and onnxscript (`pip install torch==2.13.0 onnxscript==0.7.2`) and onnx."""
    try:
        import onnxscript  # noqa: F401  (torch.onnx.export's dependency)
        import torch
    except ImportError as exc:
        raise WeightsError(f"export_torch_model needs PyTorch and onnxscript ({exc.name} is missing): "
                           f"{TORCH_PIN}") from exc
    require_onnx()
    sizes = np.asarray(supported_sizes, dtype=float).reshape(-1, 3)
    size = torch.tensor(sizes[[0, 0, 0]], dtype=torch.float32)
    example = (torch.zeros(3, 3), torch.eye(3).expand(3, 3, 3).contiguous(), size, size.clone())
    batch = torch.export.Dim(BATCH, min=1)
    module.eval()
    program = torch.onnx.export(module, example, input_names=list(INPUTS), output_names=["point_A", "normal_A"],
                                dynamic_shapes=tuple({0: batch} for _ in INPUTS), opset_version=18, dynamo=True,
                                external_data=False, verbose=False)
    model = program.model_proto
    _name_batch_axis(model)
    set_metadata(model, supported_sizes=sizes, name=name)
    return write_atomic(model, out_path)


def _name_batch_axis(model) -> None:
    """Renames the exporter's symbol for the first axis of p_AB (e.g. "s0") to BATCH
    wherever it appears in the graph's declared shapes."""
    first = model.graph.input[0].type.tensor_type.shape.dim[0]
    old = first.dim_param
    if not old:
        raise WeightsError("torch.onnx.export gave p_AB a static first axis; expected a dynamic batch axis")
    for value in [*model.graph.input, *model.graph.output, *model.graph.value_info]:
        for dim in value.type.tensor_type.shape.dim:
            if dim.dim_param == old:
                dim.dim_param = BATCH
