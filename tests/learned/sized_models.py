"""User models that declare fewer container sizes, for the bench's size tests (importable as
`sized_models` when tests/learned is on sys.path, as pytest puts it).

- `FortyFootImproved`: the shipped improved predictor declaring only the 40 ft standard box
  (1AA, 12.192 x 2.438 x 2.591 m): a model made for one container type, as a user ships it.
"""

from __future__ import annotations

import numpy as np

SIZE_1AA = [12.192, 2.438, 2.591]  # [m] ISO 668 1AA external length, width, height


class FortyFootImproved:
    """The shipped improved predictor answering only 1AA-on-1AA pairs (supported_sizes (1, 3) [m])."""

    name = "forty_foot_improved"
    supported_sizes = np.array([SIZE_1AA])

    def __init__(self):
        from learned_contact import load_predictor

        self._pred = load_predictor("improved")

    def predict(self, p_AB, R_AB, *, size_A, size_B):
        """(point_A (n, 3) [m], normal_A (n, 3)): the shipped predictor's answer."""
        return self._pred.predict(p_AB, R_AB, size_A=size_A, size_B=size_B)
