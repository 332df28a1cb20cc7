"""The numpy model: the geometric prior (prior.py), the pose features and octant frames
(encodings.py), the MLP (mlp.py) and the resting expert's gate (expert.py). Inference only:
no torch, no Drake, no onnx (the import contract in pyproject.toml)."""
