"""Checking an export: held-out probe poses, an onnxruntime session, and how closely an ONNX
file agrees with the compiled predictor (`agreement`, what `testbed export-onnx` reports).
onnxruntime is imported on use."""

from __future__ import annotations

import numpy as np

from learned_contact.data.sampling import sample
from learned_contact.export.onnx_contract import INPUTS
from learned_contact.predictors.loading import load_weights
from testbed.geometry.boxes import sat_normal


def probe_poses(n: int, seed: int, distribution: str = "general", **ranges):
    """(p_AB (n, 3), R_AB (n, 3, 3), size_A (n, 3), size_B (n, 3)) float64: the gates'
    held-out pose proposals (learned_contact.data.sampling.sample, as gates.held_out draws
    them) placed at their target penetration depth along their direction by bisecting
    the separating-axis depth (exact for overlapping boxes; no Drake labels needed).
    ranges: sample's max_depth [m] / max_tilt_deg (gates.OUTSIDE_RANGES for the
    "outside" set)."""

    props = sample(distribution, n, seed, **ranges)
    size_A, size_B = props.sizes()
    lo, hi = np.zeros(n), np.full(n, 30.0)  # [m] along direction: lo overlapping, hi separated
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        deep = sat_normal(props.base + mid[:, None] * props.direction, props.R_AB, 0.5 * size_A,
                          0.5 * size_B)[1] > props.depth
        lo, hi = np.where(deep, mid, lo), np.where(deep, hi, mid)
    return props.base + hi[:, None] * props.direction, props.R_AB, size_A, size_B


def onnx_session(path):
    """An onnxruntime InferenceSession (CPU, one thread) of the file at path."""
    import onnxruntime as ort

    opts = ort.SessionOptions()
    opts.intra_op_num_threads, opts.inter_op_num_threads = 1, 1
    return ort.InferenceSession(str(path), opts, providers=["CPUExecutionProvider"])


def run_onnx(session, p_AB, R_AB, size_A, size_B) -> dict:
    """{output name: array} of an ONNX session on poses converted to float32."""
    feed = {k: np.ascontiguousarray(v, dtype=np.float32) for k, v in zip(INPUTS, (p_AB, R_AB, size_A, size_B))}
    names = [o.name for o in session.get_outputs()]
    return dict(zip(names, session.run(names, feed)))


def agreement(path, name_or_path, *, n: int = 400, seed: int = 12345) -> dict:
    """Largest differences between the ONNX file at path and the compiled predictor
    name_or_path on n held-out general, n stacking and n resting poses (seed), both given the
    same float32-rounded poses: {"point_m", "normal_deg", "depth_m", "n"}."""

    pred = load_weights(name_or_path)
    session = onnx_session(path)
    worst = {"point_m": 0.0, "normal_deg": 0.0, "depth_m": 0.0, "n": 0}
    for k, dist in enumerate(("general", "stacking", "resting")):
        poses = [np.asarray(a, dtype=np.float32).astype(float) for a in probe_poses(n, seed + k, dist)]
        got = run_onnx(session, *poses)
        point, normal = pred.predict(poses[0], poses[1], size_A=poses[2], size_B=poses[3])
        # the angle from atan2(|a x b|, a . b): arccos of a dot product near 1 would read the float32
        # rounding of the normal (~6e-8) as ~0.02 deg
        a = got["normal_A"].astype(float)
        angle = np.arctan2(np.linalg.norm(np.cross(a, normal), axis=1), np.sum(a * normal, axis=1))
        worst["point_m"] = max(worst["point_m"], float(np.abs(got["point_A"] - point).max()))
        worst["normal_deg"] = max(worst["normal_deg"], float(np.degrees(angle).max()))
        if "depth" in got:
            depth = pred.depth(poses[0], poses[1], size_A=poses[2], size_B=poses[3])
            worst["depth_m"] = max(worst["depth_m"], float(np.abs(got["depth"] - depth).max()))
        worst["n"] += n
    return worst
