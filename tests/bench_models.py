"""Models the testbed did not ship, for the tests of learned_contact.sources and the bench.

- ONNX files built with the onnx package's helper API (`centre_line_onnx`): the "centre
  line" model answers point_A = p_AB / 2 and normal_A = p_AB / |p_AB| (the direction between
  the centres): a real, crude contact model, with switches that break the contract in one
  way each (names, types, a static batch axis, NaN outputs, unnormalised normals).
- Python objects for `module:attribute` (this module is importable as `bench_models`
  when tests/ is on sys.path): the geometric prior alone, one that answers NaN, and the
  shipped predictor with every point moved along A's x.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

CONTAINER_SIZES = [[6.058, 2.438, 2.591], [12.192, 2.438, 2.591], [12.192, 2.438, 2.896]]


def centre_line_onnx(path, *, dtype="float32", static_batch=None, input_names=("p_AB", "R_AB", "size_A", "size_B"),
                     normal_scale=1.0, nan=False, depth=False, sizes=CONTAINER_SIZES, name="centre_line",
                     metadata=None, force=None) -> Path:
    """Writes the centre-line model (see the module docstring) to `path`; each keyword
    breaks or varies one thing. Returns the path."""
    import onnx
    from onnx import TensorProto, helper

    elem = TensorProto.FLOAT if dtype == "float32" else TensorProto.DOUBLE
    n = static_batch if static_batch is not None else "n"
    shapes = {"p_AB": [n, 3], "R_AB": [n, 3, 3], "size_A": [n, 3], "size_B": [n, 3]}
    inputs = [helper.make_tensor_value_info(nm, elem, shapes[std]) for nm, std in
              zip(input_names, ("p_AB", "R_AB", "size_A", "size_B"))]
    p = input_names[0]
    inits = [helper.make_tensor("half", elem, [], [0.5]), helper.make_tensor("scale", elem, [], [normal_scale]),
             helper.make_tensor("zero", elem, [], [0.0])]
    nodes = [helper.make_node("Mul", [p, "half"], ["point_raw"]),
             helper.make_node("ReduceL2", [p, "axes"], ["length"], keepdims=1),
             helper.make_node("Div", [p, "length"], ["unit"]),
             helper.make_node("Mul", ["unit", "scale"], ["normal_A"])]
    inits.append(helper.make_tensor("axes", TensorProto.INT64, [1], [1]))
    if nan:  # 0 / 0 in every point
        nodes += [helper.make_node("Mul", ["point_raw", "zero"], ["z"]), helper.make_node("Div", ["z", "z"], ["point_A"])]
    else:
        nodes.append(helper.make_node("Identity", ["point_raw"], ["point_A"]))
    outputs = [helper.make_tensor_value_info("point_A", elem, [n, 3]), helper.make_tensor_value_info("normal_A", elem, [n, 3])]
    if depth:  # a constant 1 mm: the model's own depth answer
        nodes += [helper.make_node("ReduceSum", ["length", "axes"], ["l1"], keepdims=0),
                  helper.make_node("Mul", ["l1", "zero"], ["l0"]),
                  helper.make_node("Add", ["l0", "mm"], ["depth"])]
        inits.append(helper.make_tensor("mm", elem, [], [0.001]))
        outputs.append(helper.make_tensor_value_info("depth", elem, [n]))
    if force:  # the model's own force: a constant 1 kN, 1e6 N/m (and 2 m^2 with "area"); "no_stiffness" breaks it
        nodes += [helper.make_node("ReduceSum", ["length", "axes"], ["f1"], keepdims=0),
                  helper.make_node("Mul", ["f1", "zero"], ["f0"]),
                  helper.make_node("Add", ["f0", "kN"], ["force_n"])]
        inits.append(helper.make_tensor("kN", elem, [], [1000.0]))
        outputs.append(helper.make_tensor_value_info("force_n", elem, [n]))
        if force != "no_stiffness":
            nodes.append(helper.make_node("Add", ["f0", "k"], ["stiffness"]))
            inits.append(helper.make_tensor("k", elem, [], [1.0e6]))
            outputs.append(helper.make_tensor_value_info("stiffness", elem, [n]))
        if force == "area":
            nodes.append(helper.make_node("Add", ["f0", "two"], ["area"]))
            inits.append(helper.make_tensor("two", elem, [], [2.0]))
            outputs.append(helper.make_tensor_value_info("area", elem, [n]))
    graph = helper.make_graph(nodes, "centre_line", inputs, outputs, initializer=inits)
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 18)])
    model.ir_version = 9
    props = {"name": name}
    if sizes is not None:
        props["supported_sizes"] = json.dumps(sizes)
    props.update(metadata or {})
    helper.set_model_props(model, props)
    onnx.checker.check_model(model)
    path = Path(path)
    onnx.save(model, str(path))
    return path


def centre_line_numpy(p_AB):
    """The centre-line model's answer in numpy: (point_A (n, 3), normal_A (n, 3))."""
    p_AB = np.asarray(p_AB, dtype=float)
    return 0.5 * p_AB, p_AB / np.linalg.norm(p_AB, axis=1, keepdims=True)


class GeometricModel:
    """The improved predictor's geometric estimate alone, as a user's Python model (no
    supported_sizes, no depth: the bench fills both in)."""

    name = "geometric"

    def __init__(self):
        from learned_contact.evaluation.gates import GeometricPrior

        self._prior = GeometricPrior()

    def predict(self, p_AB, R_AB, *, size_A, size_B):
        return self._prior.predict(p_AB, R_AB, size_A=size_A, size_B=size_B)


class FortyFootOnly(GeometricModel):
    """The geometric model declaring only the two 40 ft sizes (a model for one container length)."""

    name = "forty_foot"
    supported_sizes = np.array(CONTAINER_SIZES[1:])


class NaNModel:
    """Answers NaN for every point: refused when loaded."""

    def predict(self, p_AB, R_AB, *, size_A, size_B):
        n = len(p_AB)
        return np.full((n, 3), np.nan), np.tile([0.0, 0.0, 1.0], (n, 1))


class LateNaNModel:
    """Answers like the geometric prior, except NaN for poses with B more than 3 m above A
    (the load-time probe passes; such a pose at run time is refused with a count)."""

    def __init__(self):
        self._geo = GeometricModel()

    def predict(self, p_AB, R_AB, *, size_A, size_B):
        point, normal = self._geo.predict(p_AB, R_AB, size_A=size_A, size_B=size_B)
        point = np.array(point)
        point[np.asarray(p_AB)[:, 2] > 3.0] = np.nan
        return point, normal


class ShiftedModel:
    """The shipped improved predictor with every point moved 0.3 m along A's x."""

    name = "shifted"
    SHIFT = np.array([0.3, 0.0, 0.0])

    def __init__(self):
        from learned_contact import load_predictor

        self._pred = load_predictor("improved")
        self.supported_sizes = self._pred.supported_sizes

    def predict(self, p_AB, R_AB, *, size_A, size_B):
        point, normal = self._pred.predict(p_AB, R_AB, size_A=size_A, size_B=size_B)
        return point + self.SHIFT, normal


def not_a_model():
    """A factory that returns something without predict()."""
    return 42


class ExactForce:
    """The shipped predictor with its own force: the testbed's exact field force (static_answer)
    times FACTOR, its stiffness likewise (a model that supplies a force, biased or not)."""

    FACTOR = 1.0

    def __init__(self):
        from learned_contact.sources import load_predictor

        self._inner = load_predictor("improved")
        self.supported_sizes = self._inner.supported_sizes
        self.name = f"exact_force_x{self.FACTOR:g}"

    def predict(self, p_AB, R_AB, *, size_A, size_B):
        return self._inner.predict(p_AB, R_AB, size_A=size_A, size_B=size_B)

    def force(self, p_AB, R_AB, *, size_A, size_B):
        from testbed.effects.learned_dynamics.static import static_answer

        a = static_answer(p_AB, R_AB, size_A, size_B, modulus=1e8)
        return self.FACTOR * np.linalg.norm(a.force, axis=1), self.FACTOR * np.maximum(a.stiffness, 0.0), a.area


class DoubleForce(ExactForce):
    FACTOR = 2.0


class NaNForce(ExactForce):
    def force(self, p_AB, R_AB, *, size_A, size_B):
        f, k, a = super().force(p_AB, R_AB, size_A=size_A, size_B=size_B)
        return f * np.nan, k, a
