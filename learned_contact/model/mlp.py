"""A plain multilayer perceptron evaluated with numpy (no torch).

Weights are a list of (W (in, out), b (out,)) arrays; hidden layers use `activation`
(tanh, silu or relu), the output layer is linear. Inputs are standardised with (mean, std)
stored beside the weights.
"""

from __future__ import annotations

import dataclasses

import numpy as np


def _silu(x):
    # x * sigmoid(x), with sigmoid via tanh: no overflow for large |x|
    return x * (0.5 + 0.5 * np.tanh(0.5 * x))


def _relu(x):
    return np.maximum(x, 0.0)


ACTIVATIONS = {"tanh": np.tanh, "silu": _silu, "relu": _relu}


@dataclasses.dataclass(frozen=True)
class NumpyMLP:
    """x (n, in) -> y (n, out). weights[i] (in_i, out_i), biases[i] (out_i,)."""

    weights: tuple
    biases: tuple
    activation: str
    x_mean: np.ndarray
    x_std: np.ndarray

    def __call__(self, x: np.ndarray) -> np.ndarray:
        act = ACTIVATIONS[self.activation]
        h = (x - self.x_mean) / self.x_std
        last = len(self.weights) - 1
        for i, (W, b) in enumerate(zip(self.weights, self.biases)):
            h = h @ W + b
            if i < last:
                h = act(h)
        return h

    def to_arrays(self, prefix: str) -> dict:
        out = {f"{prefix}x_mean": self.x_mean, f"{prefix}x_std": self.x_std,
               f"{prefix}activation": np.array(self.activation)}
        for i, (W, b) in enumerate(zip(self.weights, self.biases)):
            out[f"{prefix}W{i}"] = W
            out[f"{prefix}b{i}"] = b
        return out

    @classmethod
    def from_arrays(cls, arrays, prefix: str) -> "NumpyMLP":
        n = sum(1 for k in arrays if k.startswith(f"{prefix}W"))
        return cls(
            weights=tuple(np.ascontiguousarray(arrays[f"{prefix}W{i}"], dtype=float) for i in range(n)),
            biases=tuple(np.asarray(arrays[f"{prefix}b{i}"], dtype=float) for i in range(n)),
            activation=str(arrays[f"{prefix}activation"]),
            x_mean=np.asarray(arrays[f"{prefix}x_mean"], dtype=float),
            x_std=np.asarray(arrays[f"{prefix}x_std"], dtype=float),
        )
