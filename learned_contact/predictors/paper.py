"""The paper's model, faithfully: 6 inputs (relative position + Euler angles, after the
symmetry reduction into A's positive octant), 4 outputs (spherical angles of the
contact point direction and the force direction, encodings.paper_outputs), two tanh
hidden layers of 20 and 18 units, linear outputs, trained by backpropagation with
momentum (SGD), stopped early on a validation set, restarted from several random
initialisations keeping the best on validation (learned_contact.training.paper, which
needs torch; this module is inference only).

`PaperPredictor` (kind "paper") answers the common interface
(learned_contact.interface.Predictor): its outputs are decoded into a point on A's
surface along the predicted direction and a unit force direction.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from learned_contact.model.encodings import canonicalise, from_spherical, octant_signs, proper
from learned_contact.model.mlp import NumpyMLP
from learned_contact.predictors.base import MLPPredictor
from testbed.geometry.boxes import sat_normal
from testbed.geometry.rotations import rpy_from_rotation


def paper_inputs(p_AB, R_AB) -> np.ndarray:
    """(n, 6): canonical relative position [m] and roll-pitch-yaw [rad] of B in A."""
    _, p_c, R_c = canonicalise(p_AB, R_AB)
    return np.concatenate([p_c, rpy_from_rotation(proper(R_c))], axis=1)


def predict_paper(mlp: NumpyMLP, p_AB, R_AB) -> np.ndarray:
    """(n, 4) the paper model's outputs [rad] for poses (n, 3), (n, 3, 3)."""
    return mlp(paper_inputs(p_AB, R_AB))


def decode_paper(y, p_AB, size_A):
    """Point and normal from the paper MLP's outputs y (n, 4) [rad].

    The first two outputs are the spherical angles of the contact point's direction from
    A's centre in the canonical (positive-octant) frame; the point is where that ray
    leaves box A (the paper: "the length ... can be obtained from its direction, since it
    must lie on the surface of the cube"). The last two are the force direction.
    p_AB (n, 3) [m] (for the octant), size_A (n, 3) or (3,) [m]. Returns (point (n, 3)
    [m], normal (n, 3) unit A->B) in A's frame.
    """
    S = octant_signs(p_AB)
    d = from_spherical(y[:, :2])
    reach = np.max(np.abs(d) / (0.5 * np.asarray(size_A, dtype=float)), axis=1)  # (n,)
    point = S * d / reach[:, None]
    normal = S * from_spherical(y[:, 2:4])
    return point, normal / np.linalg.norm(normal, axis=1, keepdims=True)


@dataclasses.dataclass(frozen=True)
class PaperPredictor(MLPPredictor):
    """The paper's 6-20-18-4 MLP behind the common predictor interface. Its point lies
    on A's surface for every pose, so outside="clip" never moves it; outside="raise"
    refuses poses outside DOMAIN_DEPTH like the improved predictor."""

    kind = "paper"

    def _predict_numpy(self, p, R, sA, sB, with_depth: bool):
        point, normal = decode_paper(self.mlp(paper_inputs(p, R)), p, sA)
        depth = sat_normal(p, R, 0.5 * sA, 0.5 * sB)[1] if with_depth else np.full(len(p), np.nan)
        return point, normal, depth
