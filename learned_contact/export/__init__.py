"""Exporting predictors to ONNX (onnx_export.py) under the bench's contract (onnx_contract.py),
as graphs built node by node (onnx_predictors.py from onnx_blocks.py, onnx_prior.py,
onnx_quadrature.py and onnx_network.py), and checking an export (onnx_check.py): needs the
onnx package."""
