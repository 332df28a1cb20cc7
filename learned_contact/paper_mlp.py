"""The paper's model, faithfully: 6 inputs (relative position + Euler angles, after the
symmetry reduction into A's positive octant), 4 outputs (spherical angles of the
contact point direction and the force direction, encodings.paper_outputs), two tanh
hidden layers of 20 and 18 units, linear outputs, trained by backpropagation with
momentum (SGD), stopped early on a validation set, restarted from several random
initialisations keeping the best on validation. Needs torch for training only.

`PaperPredictor` (kind "paper") answers the common interface
(learned_contact.interface.Predictor): its outputs are decoded into a point on A's
surface along the predicted direction and a unit force direction.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from learned_contact.base import MLPPredictor
from learned_contact.encodings import canonicalise, from_spherical, octant_signs, paper_outputs, proper
from learned_contact.mlp import NumpyMLP
from testbed.geometry.boxes import sat_normal
from testbed.geometry.rotations import rpy_from_rotation
from testbed.progress import progress as progress_bar


@dataclasses.dataclass(frozen=True)
class PaperConfig:
    """Training settings of the paper-faithful model (sizes as in the paper's Table 2)."""

    hidden: tuple[int, ...] = (20, 18)
    n_train: int = 10_000
    n_val: int = 6_000
    n_test: int = 50_000
    restarts: int = 4
    learning_rate: float = 0.01
    momentum: float = 0.9
    batch: int = 32
    max_epochs: int = 150
    patience: int = 15  # epochs without validation improvement before stopping
    init_range: float = 0.5  # uniform(-r, r) initial weights (scaled by 1/sqrt(fan_in))
    torch_threads: int = 1  # tiny batches: more threads only add overhead


def paper_inputs(p_AB, R_AB) -> np.ndarray:
    """(n, 6): canonical relative position [m] and roll-pitch-yaw [rad] of B in A."""
    _, p_c, R_c = canonicalise(p_AB, R_AB)
    return np.concatenate([p_c, rpy_from_rotation(proper(R_c))], axis=1)


def paper_targets(ds) -> np.ndarray:
    """(n, 4) the paper's outputs of a Dataset's labels [rad]."""
    return paper_outputs(ds.cop, ds.normal, octant_signs(ds.p_AB))


def train_paper(train, val, config: PaperConfig = PaperConfig(), *, seed: int = 0, progress: bool = True):
    """Trains the paper's MLP on Datasets `train`, `val`. Returns (NumpyMLP mapping
    paper_inputs -> paper outputs [rad], info dict with per-restart validation MSE)."""
    import torch


    torch.manual_seed(seed)
    torch.set_num_threads(config.torch_threads)
    x_tr, x_va = paper_inputs(train.p_AB, train.R_AB), paper_inputs(val.p_AB, val.R_AB)
    y_tr, y_va = paper_targets(train), paper_targets(val)
    x_mean, x_std = x_tr.mean(0), x_tr.std(0) + 1e-9
    y_mean, y_std = y_tr.mean(0), y_tr.std(0) + 1e-9
    t = lambda a: torch.tensor(a, dtype=torch.float32)  # noqa: E731
    X, Y = t((x_tr - x_mean) / x_std), t((y_tr - y_mean) / y_std)
    Xv, Yv = t((x_va - x_mean) / x_std), t((y_va - y_mean) / y_std)
    best, best_loss, losses, epochs = None, np.inf, [], []
    bar = progress_bar(total=config.restarts, desc="paper MLP restarts", disable=not progress)
    for _ in range(config.restarts):
        sizes = (6, *config.hidden, 4)
        layers = []
        for i in range(len(sizes) - 1):
            lin = torch.nn.Linear(sizes[i], sizes[i + 1])
            r = config.init_range * np.sqrt(3.0 / sizes[i])
            torch.nn.init.uniform_(lin.weight, -r, r)
            torch.nn.init.zeros_(lin.bias)
            layers += [lin, torch.nn.Tanh()] if i < len(sizes) - 2 else [lin]
        net = torch.nn.Sequential(*layers)
        opt = torch.optim.SGD(net.parameters(), lr=config.learning_rate, momentum=config.momentum)
        run_best, run_state, stale, epoch = np.inf, None, 0, 0
        for epoch in range(config.max_epochs):  # noqa: B007 - read after the loop (epochs run)
            perm = torch.randperm(len(X))
            for i in range(0, len(X), config.batch):
                b = perm[i:i + config.batch]
                loss = torch.mean((net(X[b]) - Y[b]) ** 2)
                opt.zero_grad()
                loss.backward()
                opt.step()
            with torch.no_grad():
                v = float(torch.mean((net(Xv) - Yv) ** 2))
            if v < run_best - 1e-5:
                run_best, stale = v, 0
                run_state = [p.detach().clone() for p in net.parameters()]
            else:
                stale += 1
                if stale >= config.patience:
                    break
        losses.append(run_best)
        epochs.append(epoch + 1)
        if run_best < best_loss:
            best_loss, best = run_best, run_state
        bar.update(1)
    bar.close()
    weights = [best[i].numpy().T.astype(float) for i in range(0, len(best), 2)]
    biases = [best[i].numpy().astype(float) for i in range(1, len(best), 2)]
    weights[-1] = weights[-1] * y_std[None, :]  # fold the target scaling into the output layer
    biases[-1] = biases[-1] * y_std + y_mean
    mlp = NumpyMLP(tuple(weights), tuple(biases), "tanh", x_mean, x_std)
    return mlp, {"val_mse_per_restart": losses, "epochs_per_restart": epochs, "best_val_mse": float(best_loss)}


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

    def _predict_compiled(self, p, R, sA, sB, with_depth: bool):
        from learned_contact.compiled import paper_predict

        return paper_predict(p, R, sA, sB, self.supported_sizes, *self._packed, with_depth)
