"""A user's contact model for `judge_your_model.py`: answers the centre of the overlap of B's
bottom face with A's top face (a crude geometric model), in the contract of
learned_contact/README.md: batches of p_AB (n, 3) [m] and R_AB (n, 3, 3) (B in A's frame),
full sizes (n, 3) [m]; returns point_A (n, 3) [m] and normal_A (n, 3) unit from A into B.
A PyTorch model does the same behind numpy arrays (or export it to ONNX)."""

import numpy as np


class OverlapCentre:
    name = "overlap_centre"
    supported_sizes = [[12.192, 2.438, 2.591], [12.192, 2.438, 2.896], [6.058, 2.438, 2.591]]

    def predict(self, p_AB, R_AB, *, size_A, size_B):
        p = np.asarray(p_AB, dtype=float)
        h_A, h_B = 0.5 * np.asarray(size_A, dtype=float), 0.5 * np.asarray(size_B, dtype=float)
        # B's footprint half extents in A's x and y (its yaw taken into account)
        reach = np.abs(np.asarray(R_AB)[:, :2, :2]) @ h_B[:, :2, None]
        low = np.maximum(-h_A[:, :2], p[:, :2] - reach[:, :, 0])
        high = np.minimum(h_A[:, :2], p[:, :2] + reach[:, :, 0])
        point = np.column_stack([0.5 * (low + high), np.sign(p[:, 2]) * h_A[:, 2]])
        normal = np.zeros_like(p)
        normal[:, 2] = np.sign(p[:, 2])
        return point, normal
