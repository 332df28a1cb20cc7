"""The training data: the labelled sets of the default run (`default_datasets`, labelled with
Drake and cached by learned_contact.data), their training / validation splits, and the
network's inputs and targets in the canonical frame (`improved_inputs`)."""

from __future__ import annotations

import dataclasses

import numpy as np

from learned_contact.data.labels import Dataset, make_dataset
from learned_contact.model.encodings import canonicalise, features, frame_blend, reflect
from learned_contact.training.config import SEED_TEST, SEED_TRAIN, TrainConfig


def split_validation(ds: Dataset, n_val: int):
    """(training, validation) Datasets: the last n_val rows of ds held for validation."""
    n = len(ds)
    return ds.subset(slice(0, n - n_val)), ds.subset(slice(n - n_val, n))


def concat_datasets(sets) -> Dataset:
    """The Datasets `sets` as one (rows in order; distribution names joined with '+')."""
    fields = {}
    for f in dataclasses.fields(Dataset):
        vals = [getattr(d, f.name) for d in sets]
        fields[f.name] = (np.concatenate(vals) if all(isinstance(v, np.ndarray) for v in vals)
                          else None if f.name == "force" else vals[0])
    fields["n_dropped"] = sum(d.n_dropped for d in sets)
    fields["distribution"] = "+".join(d.distribution for d in sets)
    return Dataset(**fields)


def improved_inputs(ds: Dataset, mirror: bool = False, with_depth: bool = False):
    """(x (n, F), point_est (n, 3), normal_est (n, 3), point_c (n, 3), normal_c (n, 3)):
    features, geometric estimate and labels, all in the canonical frame. mirror: also
    every pose within encodings.SYMMETRY_BAND of a reflection plane answered in each
    neighbouring octant's frame that the predictor blends in there (frame_blend), so
    the network learns both frames alike (rows appended after the n canonical ones).
    with_depth: a sixth array, each row's target penetration depth [m]."""
    S, p_c, R_c = canonicalise(ds.p_AB, ds.R_AB)
    x, point_est, normal_est = features(p_c, R_c, 0.5 * ds.size_A, 0.5 * ds.size_B)
    out = [(x, point_est, normal_est, S * ds.cop, S * ds.normal, ds.depth)]
    for sigma, coef in (frame_blend(ds.p_AB)[1:] if mirror else []):
        rows = np.flatnonzero(coef > 0.0)
        if len(rows) == 0:
            continue
        sg = sigma[rows]
        p_m, R_m = reflect(sg, ds.p_AB[rows], ds.R_AB[rows])
        xm, pm, nm = features(p_m, R_m, 0.5 * ds.size_A[rows], 0.5 * ds.size_B[rows])
        out.append((xm, pm, nm, sg * ds.cop[rows], sg * ds.normal[rows], ds.depth[rows]))
    return tuple(np.concatenate(parts) for parts in zip(*out))[:6 if with_depth else 5]


def default_datasets(config: TrainConfig, *, progress: bool = True) -> dict:
    """The labelled sets of the default run (cached): general/stacking pools and tests."""
    kw = dict(types=config.types, workers=config.workers, progress=progress)
    s_tr, s_te = 10 * config.seed + SEED_TRAIN, 10 * config.seed + SEED_TEST
    out = {
        "general": make_dataset("general", config.n_general, s_tr, **kw),
        "stacking": make_dataset("stacking", config.n_stacking, s_tr, **kw),
        "general_test": make_dataset("general", config.n_test_general, s_te, **kw),
        "stacking_test": make_dataset("stacking", config.n_test_stacking, s_te, **kw),
    }
    if config.n_resting:
        out["resting"] = make_dataset("resting", config.n_resting, s_tr, **kw)
    if config.expert is not None:
        out["expert_resting"] = make_dataset("resting", config.expert.n_resting, s_tr, **kw)
        out["expert_resting_wide"] = make_dataset("resting_wide", config.expert.n_resting_wide, s_tr, **kw)
        if config.expert.n_resting_level:
            out["expert_resting_level"] = make_dataset("resting_level", config.expert.n_resting_level, s_tr, **kw)
        for dist in ("resting_wider", "resting_support"):
            n = getattr(config.expert, f"n_{dist}")
            if n:
                out[f"expert_{dist}"] = make_dataset(dist, n, s_tr, **kw)
    if config.n_test_resting:
        out["resting_test"] = make_dataset("resting", config.n_test_resting, s_te, **kw)
    return out


EXPERT_SETS = ("expert_resting", "expert_resting_wide", "expert_resting_level", "expert_resting_wider",
               "expert_resting_support")
NARROW_SETS = EXPERT_SETS[:3]
