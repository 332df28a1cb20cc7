"""Compiled inference for the contact predictors (numba, cached machine code).

Why numba: the kernels are written as plain loops over numpy arrays, in the same
operations as the numpy reference (learned_contact.model.prior / encodings / mlp), so both
paths can be compared line by line and agree to rounding; `@njit(cache=True)` stores the
machine code beside the source (or in the user's cache directory when that is not
writable), so a fresh process loads it instead of compiling (see `python -m
learned_contact.evaluation.benchmark --first-call`); the wheel stays pure Python (no C toolchain
at install time, no per-platform builds of our own); and numba is a well kept,
widely used project that follows numpy releases. Cython or a C extension would need a
compiler in the wheel path; torch/ONNX runtimes add per-call framework overhead that
dominates a 6-20-18-4 network.

Layout: geometry.py (one-pose SAT, clipped patch, canonicalisation), kernels.py (input
checks, features, MLP, the fused per-predictor loops). The predictors in
learned_contact.predictors.improved and learned_contact.predictors.paper call these when loaded with
`load_predictor(..., compiled=True)` (the default).
"""

from learned_contact.compiled.kernels import box_depth, improved_predict, pack_improved, pack_mlp, paper_predict

__all__ = ["box_depth", "improved_predict", "pack_improved", "pack_mlp", "paper_predict"]
