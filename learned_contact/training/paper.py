"""Training the paper's 6-20-18-4 MLP (learned_contact.predictors.paper): backpropagation
with momentum (SGD), early stopping on a validation set, several random restarts keeping the
best on validation. Needs torch (the `train` extra)."""

from __future__ import annotations

import dataclasses

import numpy as np

from learned_contact.model.encodings import octant_signs, paper_outputs
from learned_contact.model.mlp import NumpyMLP
from learned_contact.predictors.paper import paper_inputs
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


