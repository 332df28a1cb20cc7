"""The training loop: `train_improved` (the correction MLP: Adam, one-cycle schedule, the best
epoch on validation), the resting expert on its sets (`train_expert`) and re-fitting a
shipped predictor's expert (`refit_expert`). Needs torch (imported on use)."""

from __future__ import annotations

import dataclasses

import numpy as np

from learned_contact.data.labels import Dataset, make_dataset
from learned_contact.data.sampling import MAX_DEPTH
from learned_contact.model.mlp import NumpyMLP
from learned_contact.predictors.improved import POINT_STEP, ContactPredictor
from learned_contact.training.config import SEED_TRAIN, TrainConfig
from learned_contact.training.datasets import EXPERT_SETS, NARROW_SETS, concat_datasets, improved_inputs, split_validation
from testbed.progress import progress as progress_bar


def train_improved(train: Dataset, val: Dataset, config: TrainConfig, *, progress: bool = True):
    """Trains the correction MLP (Adam, one-cycle schedule, best epoch on validation).
    Returns (NumpyMLP, info dict)."""
    import torch

    torch.manual_seed(config.seed)
    torch.set_num_threads(config.torch_threads)
    x, pe, ne, pc, nc, dw = improved_inputs(train, mirror=config.mirror, with_depth=True)
    xv, pev, nev, pcv, ncv, dwv = improved_inputs(val, with_depth=True)
    dw, dwv = 1.0 + config.deep_weight * dw / MAX_DEPTH, 1.0 + config.deep_weight * dwv / MAX_DEPTH
    x_mean, x_std = x.mean(0), x.std(0) + 1e-6
    t = lambda a: torch.tensor(a, dtype=torch.float32)  # noqa: E731
    X, PE, NE, PC, NC, W = t((x - x_mean) / x_std), t(pe), t(ne), t(pc), t(nc), t(dw)
    Xv, PEv, NEv, PCv, NCv, Wv = t((xv - x_mean) / x_std), t(pev), t(nev), t(pcv), t(ncv), t(dwv)
    act = {"silu": torch.nn.SiLU, "tanh": torch.nn.Tanh, "relu": torch.nn.ReLU}[config.activation]
    sizes = (x.shape[1], *config.hidden, 6)
    layers = []
    for i in range(len(sizes) - 1):
        layers.append(torch.nn.Linear(sizes[i], sizes[i + 1]))
        if i < len(sizes) - 2:
            layers.append(act())
    net = torch.nn.Sequential(*layers)
    torch.nn.init.zeros_(net[-1].weight)  # start from the geometric estimate
    torch.nn.init.zeros_(net[-1].bias)
    steps = (len(X) + config.batch - 1) // config.batch
    opt = torch.optim.Adam(net.parameters(), lr=config.learning_rate)
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, config.learning_rate, total_steps=config.epochs * steps)

    def forward(xb, peb, neb):
        y = net(xb)
        return peb + POINT_STEP * y[:, :3], torch.nn.functional.normalize(neb + y[:, 3:], dim=1)

    def loss_fn(p, n, pc_, nc_, w):
        lp = torch.nn.functional.smooth_l1_loss(p, pc_, beta=config.point_beta) / config.point_scale
        ln = (w * ((n - nc_) ** 2).sum(1)).mean() / config.normal_scale**2
        return lp + ln

    best, best_state, history = np.inf, None, []
    bar = progress_bar(range(config.epochs), desc="improved MLP epochs", disable=not progress)
    for _ in bar:
        perm = torch.randperm(len(X))
        for i in range(0, len(X), config.batch):
            b = perm[i:i + config.batch]
            loss = loss_fn(*forward(X[b], PE[b], NE[b]), PC[b], NC[b], W[b])
            opt.zero_grad()
            loss.backward()
            opt.step()
            sched.step()
        with torch.no_grad():
            v = float(loss_fn(*forward(Xv, PEv, NEv), PCv, NCv, Wv))
        history.append(v)
        bar.set_postfix(val=f"{v:.4g}")
        if v < best:
            best, best_state = v, [p.detach().clone() for p in net.parameters()]
    weights = tuple(best_state[i].numpy().T.astype(float) for i in range(0, len(best_state), 2))
    biases = tuple(best_state[i].numpy().astype(float) for i in range(1, len(best_state), 2))
    mlp = NumpyMLP(weights, biases, config.activation, x_mean, x_std)
    return mlp, {"val_loss_history": history, "best_val_loss": best}


def train_expert(data: dict, config: TrainConfig, *, progress: bool = True):
    """The resting expert of `config` on the labelled sets of default_datasets:
    (NumpyMLP, info dict, validation Datasets per distribution). The main network's
    recipe with ExpertConfig's epochs and point beta, on the resting sets only (10 % of
    each held for validation; the narrow sets' training part repeated narrow_repeat times)."""
    ex = config.expert
    pools = [(k, *split_validation(data[k], int(config.n_val_fraction * len(data[k])))) for k in EXPERT_SETS if k in data]
    train = [t for k, t, _ in pools for _ in range(ex.narrow_repeat if k in NARROW_SETS else 1)]
    recipe = dataclasses.replace(config, epochs=ex.epochs, point_beta=ex.point_beta, mirror=False, deep_weight=0.0)
    mlp, info = train_improved(concat_datasets(train), concat_datasets([v for _, _, v in pools]), recipe, progress=progress)
    return mlp, info, tuple(v for _, _, v in pools)


def refit_expert(base: ContactPredictor, config: TrainConfig, *, progress: bool = True):
    """(ContactPredictor, info): `base`'s main network with a resting expert re-fitted by
    config.expert (its sets labelled or read from the cache, sampling seed 10 * config.seed +
    SEED_TRAIN) and its gate config.expert.domain(); the main network is not retrained."""
    kw = dict(types=config.types, workers=config.workers, progress=progress)
    ex, s_tr = config.expert, 10 * config.seed + SEED_TRAIN
    data = {f"expert_{dist}": make_dataset(dist, n, s_tr, **kw)
            for dist, n in (("resting", ex.n_resting), ("resting_wide", ex.n_resting_wide),
                            ("resting_level", ex.n_resting_level), ("resting_wider", ex.n_resting_wider),
                            ("resting_support", ex.n_resting_support)) if n}
    expert, info, _ = train_expert(data, config, progress=progress)
    meta = {**base.meta, "config": {**base.meta.get("config", {}), "expert": dataclasses.asdict(ex)},
            "train_info": {**base.meta.get("train_info", {}), "expert_best_val_loss": info["best_val_loss"]}}
    return dataclasses.replace(base, expert=expert, expert_domain=ex.domain(), meta=meta), info
