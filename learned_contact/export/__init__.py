"""Exporting predictors to ONNX (onnx_export.py) as graphs built node by node (onnx_graph.py):
needs the onnx package."""
