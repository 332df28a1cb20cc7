"""The network's graph: learned_contact.model.mlp.NumpyMLP (standardised inputs, hidden
layers, linear output) in standard ONNX operators."""

from __future__ import annotations

from learned_contact.export.onnx_blocks import Graph


def mlp(g: Graph, x, net):
    """learned_contact.model.mlp.NumpyMLP on x (n, in): standardise, hidden layers, linear output."""
    h = g.div(g.sub(x, g.f(net.x_mean[None])), g.f(net.x_std[None]))
    last = len(net.weights) - 1
    for i, (W, b) in enumerate(zip(net.weights, net.biases)):
        h = g.add(g.op("MatMul", h, g.f(W)), g.f(b[None]))
        if i < last:
            if net.activation == "tanh":
                h = g.op("Tanh", h)
            elif net.activation == "relu":
                h = g.op("Relu", h)
            else:  # silu, written as mlp._silu: x * (0.5 + 0.5 tanh(x / 2))
                h = g.mul(h, g.add(g.f(0.5), g.mul(g.f(0.5), g.op("Tanh", g.mul(g.f(0.5), h)))))
    return h
