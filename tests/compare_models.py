"""A deliberately wrong predictor for the tests of `testbed compare`'s verdicts, loaded as
`compare_models:TiltedNormalModel` (tests/ on sys.path, or the working directory there)."""

from __future__ import annotations

import numpy as np

from learned_contact import load_predictor


class TiltedNormalModel:
    """The shipped improved predictor with every normal tilted TILT_DEG about A's x axis:
    the contact force of a stacked box gains a sideways part of tan(TILT_DEG) of its
    weight, more than friction holds, so the top box slides off its place without blowing up."""

    name = "tilted"
    TILT_DEG = 30.0

    def __init__(self):
        self._pred = load_predictor("improved")
        self.supported_sizes = self._pred.supported_sizes
        a = np.radians(self.TILT_DEG)
        self._R = np.array([[1.0, 0.0, 0.0], [0.0, np.cos(a), -np.sin(a)], [0.0, np.sin(a), np.cos(a)]])

    def predict(self, p_AB, R_AB, *, size_A, size_B):
        point, normal = self._pred.predict(p_AB, R_AB, size_A=size_A, size_B=size_B)
        return point, np.asarray(normal) @ self._R.T
