"""Deliberately perturbed predictors: what the closed loop can tell apart.

Each is a learned_contact.sources `module:attribute` factory (no arguments) over the shipped
improved predictor, answering predict(p_AB, R_AB, *, size_A, size_B) -> (point_A (n, 3)
[m] in A's frame, unit normal_A (n, 3) from A into B):

- `bias_5cm`: every point moved 5 cm along A's +x. In the overhang scenes A is the welded
  base and the overhang lies along its +x, so this is a bias toward the overhang;
- `Biased(bias_m)`, `TiltedNormal(deg)`: any bias [m] along A's x, any tilt [deg] of the
  normal about A's y (its top toward A's +x).

`testbed validate` runs SENSITIVITY_CHECK beside the shipped predictors in every closed-loop
scene (reported, not gated): a scene where it still passes every gate cannot tell a model
whose every contact point is 5 cm wrong from the shipped one (on near-parallel
faces the loop settles wherever the predicted point sits under the centre of mass).
"""

from __future__ import annotations

import numpy as np

from learned_contact import load_predictor, sources

SENSITIVITY_CHECK = "testbed.validation.sensitivity:bias_5cm"


class Biased:
    """The improved predictor with every point moved `bias_m` [m] along A's +x."""

    def __init__(self, bias_m: float):
        self._pred = load_predictor(sources.DEFAULT)
        self.supported_sizes = self._pred.supported_sizes
        self.bias_m = float(bias_m)
        self.name = f"improved, points {bias_m * 100:+g} cm along A's x"

    def predict(self, p_AB, R_AB, *, size_A, size_B):
        point, normal = self._pred.predict(p_AB, R_AB, size_A=size_A, size_B=size_B)
        return np.asarray(point) + np.array([self.bias_m, 0.0, 0.0]), normal


class TiltedNormal:
    """The improved predictor with every normal rotated `deg` about A's y (A's z toward A's +x)."""

    def __init__(self, deg: float):
        self._pred = load_predictor(sources.DEFAULT)
        self.supported_sizes = self._pred.supported_sizes
        a = np.radians(deg)
        self._R = np.array([[np.cos(a), 0.0, np.sin(a)], [0.0, 1.0, 0.0], [-np.sin(a), 0.0, np.cos(a)]])
        self.name = f"improved, normals tilted {deg:g} deg"

    def predict(self, p_AB, R_AB, *, size_A, size_B):
        point, normal = self._pred.predict(p_AB, R_AB, size_A=size_A, size_B=size_B)
        return point, np.asarray(normal) @ self._R.T


def bias_5cm() -> Biased:
    """The sensitivity check: every point 5 cm along A's +x."""
    return Biased(0.05)
