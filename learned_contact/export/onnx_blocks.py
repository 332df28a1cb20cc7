"""The building blocks of the exported graphs: `Graph`, a small node/initializer collector
over the `onnx` package's helper API (opset 17), and the vector operations every graph
uses (cross and dot products, norms, matrix-vector products, atan2).

Every function here takes a `Graph` and tensor names and returns tensor names; the
first axis of every tensor is the batch (n, dynamic). `Graph.dt` is the numpy float dtype
constants and computations are in. The onnx package is imported on use.
"""

from __future__ import annotations

import numpy as np

OPSET = 17
IR_VERSION = 8  # onnx 1.23 writes IR 11 by default; IR 8 (opset <= 17) loads in onnxruntime >= 1.12
I64 = np.int64
NEXT = np.array([1, 2, 0], dtype=I64)  # (m + 1) % 3
NEXT2 = np.array([2, 0, 1], dtype=I64)  # (m + 2) % 3


class Graph:
    """Collects nodes and initializers; `op` adds one node and returns its output name."""

    def __init__(self, dt=np.float64):
        self.dt = np.dtype(dt)
        self.nodes, self.initializers, self._consts, self._n = [], [], {}, 0

    def name(self, hint: str) -> str:
        self._n += 1
        return f"{hint}_{self._n}"

    def const(self, value, dtype=None) -> str:
        """An initializer holding `value` (in self.dt unless dtype is given); shared by value."""
        from onnx import numpy_helper

        arr = np.asarray(value, dtype=dtype or self.dt)
        key = (arr.dtype.str, arr.shape, arr.tobytes())
        if key not in self._consts:
            name = self.name("c")
            self.initializers.append(numpy_helper.from_array(arr, name))
            self._consts[key] = name
        return self._consts[key]

    def op(self, op_type: str, *inputs, n_out: int = 1, out=None, **attrs):
        from onnx import helper

        outs = [out] if out is not None else [self.name(op_type.lower()) for _ in range(n_out)]
        self.nodes.append(helper.make_node(op_type, list(inputs), outs, **attrs))
        return outs[0] if n_out == 1 else outs

    # ---------------------------------------------------------------- shorthands
    def f(self, value) -> str:
        return self.const(value)

    def i(self, value) -> str:
        return self.const(value, I64)

    def add(self, a, b):
        return self.op("Add", a, b)

    def sub(self, a, b):
        return self.op("Sub", a, b)

    def mul(self, a, b):
        return self.op("Mul", a, b)

    def div(self, a, b):
        return self.op("Div", a, b)

    def where(self, c, a, b):
        return self.op("Where", c, a, b)

    def sign_ge0(self, x):
        """+1 where x >= 0, else -1 (np.where(x >= 0, 1, -1))."""
        return self.where(self.op("Less", x, self.f(0.0)), self.f(-1.0), self.f(1.0))

    def take(self, x, idx, axis):
        """x[..., idx, ...] along `axis` with a constant index list (or int: the axis drops)."""
        return self.op("Gather", x, self.i(idx), axis=axis)

    def pick(self, x, k, axis):
        """x gathered along `axis` with a per-row index tensor k broadcast to x's other
        axes (np.take_along_axis); k has x's rank with size 1 on `axis`."""
        return self.op("GatherElements", x, k, axis=axis)

    def unsq(self, x, axes):
        return self.op("Unsqueeze", x, self.i(axes))

    def sq(self, x, axes):
        return self.op("Squeeze", x, self.i(axes))

    def reshape(self, x, shape):
        return self.op("Reshape", x, self.i(shape))

    def rsum(self, x, axis, keep=0):
        return self.op("ReduceSum", x, self.i([axis]), keepdims=keep)

    def rmin(self, x, axis, keep=0):
        return self.op("ReduceMin", x, axes=[axis], keepdims=keep)

    def rmax(self, x, axis, keep=0):
        return self.op("ReduceMax", x, axes=[axis], keepdims=keep)

    def clip(self, x, lo, hi):
        return self.op("Max", self.op("Min", x, hi), lo)

    def onehot(self, k, depth: int, dtype=bool):
        """(n, depth) one-hot of k (n, 1) int64, as bool or self.dt."""
        hit = self.op("Equal", k, self.i(np.arange(depth)[None, :]))
        return hit if dtype is bool else self.op("Cast", hit, to=onnx_type(self.dt))

    def vec_at(self, x3, k):
        """(n, 1) x3[n, k[n]] for x3 (n, 3) and k (n, 1) int64."""
        return self.pick(x3, k, 1)

    def row_at(self, M, k):
        """(n, 3) M[n, k[n], :] for M (n, 3, 3) and k (n, 1) int64."""
        kk = self.op("Expand", self.unsq(k, [2]), self.i([1, 1, 3]))
        return self.sq(self.pick(M, kk, 1), [1])


def onnx_type(dt) -> int:
    """The TensorProto element type of a numpy float dtype."""
    from onnx import TensorProto

    return {np.dtype(np.float32): TensorProto.FLOAT, np.dtype(np.float64): TensorProto.DOUBLE}[np.dtype(dt)]


def cross(g: Graph, a, b):
    """a x b along the last axis (size 3)."""
    return g.sub(g.mul(g.take(a, [1, 2, 0], -1), g.take(b, [2, 0, 1], -1)),
                 g.mul(g.take(a, [2, 0, 1], -1), g.take(b, [1, 2, 0], -1)))


def matvec(g: Graph, M, v):
    """(n, r) M @ v for M (n, r, 3), v (n, 3)."""
    return g.sq(g.op("MatMul", M, g.unsq(v, [2])), [2])


def transpose(g: Graph, M):
    return g.op("Transpose", M, perm=[0, 2, 1])


def dot(g: Graph, a, b, keep: int = 0):
    """sum(a * b) over the last axis (size 3)."""
    return g.op("ReduceSum", g.mul(a, b), g.i([-1]), keepdims=keep)


def norm(g: Graph, a, keep: int = 1):
    """The Euclidean norm over the last axis (np.linalg.norm(a, axis=-1, keepdims=keep))."""
    return g.op("Sqrt", dot(g, a, a, keep))


def batch_shape(g: Graph, like, dims):
    """The int64 shape (n, *dims), n the first axis of tensor `like`."""
    n = g.op("Slice", g.op("Shape", like), g.i([0]), g.i([1]), g.i([0]))
    return g.op("Concat", n, g.i(list(dims)), axis=0)


def atan2(g: Graph, y, x):
    """np.arctan2(y, x) from Atan and Where (ONNX has no Atan2): atan(y/x) (+-pi for
    x < 0) where |x| >= |y|, else +-pi/2 - atan(x/y)."""
    zero = g.f(0.0)
    wide = g.op("GreaterOrEqual", g.op("Abs", x), g.op("Abs", y))
    safe_x = g.where(g.op("Equal", x, zero), g.f(1.0), x)
    safe_y = g.where(g.op("Equal", y, zero), g.f(1.0), y)
    a = g.op("Atan", g.div(y, safe_x))
    a = g.add(a, g.where(g.op("Less", x, zero), g.mul(g.sign_ge0(y), g.f(np.pi)), zero))
    b = g.sub(g.mul(g.sign_ge0(y), g.f(np.pi / 2)), g.op("Atan", g.div(x, safe_y)))
    return g.where(wide, a, b)
