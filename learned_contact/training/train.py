"""Training of the improved predictor and the default run that makes shipped/.

    from learned_contact.training.train import train_default
    train_default("learned_contact/shipped", seed=0)

The run, by module: config.py (TrainConfig, ExpertConfig, the candidate recipes), datasets.py
(the labelled sets, splits and the network's inputs), loop.py (the training loop and the
resting expert), here: the default run end to end, the metrics and the files it writes
(weights.npz, paper_weights.npz, config.json, metrics.json, report.md), and re-scoring.

Needs torch (training only) and Drake (labels). Datasets are cached (cache.py), so a
second run with the same seed skips labelling.
"""

from __future__ import annotations

import dataclasses
import json
import time
from pathlib import Path

import numpy as np

from learned_contact.evaluation.metrics import evaluate, paper_table
from learned_contact.evaluation.report import weights_digest, write_report
from learned_contact.model.mlp import NumpyMLP
from learned_contact.predictors.improved import ANSWERED_SIZE_RANGE, SHIPPED_DIR, ContactPredictor, answered_sizes
from learned_contact.predictors.loading import load_weights
from learned_contact.predictors.paper import PaperPredictor, predict_paper
from learned_contact.training.config import RESTING_RECIPE, SUPPORT_EXPERT, TrainConfig
from learned_contact.training.datasets import EXPERT_SETS, concat_datasets, default_datasets, split_validation
from learned_contact.training.loop import refit_expert, train_expert, train_improved
from learned_contact.training.paper import paper_targets, train_paper
from testbed.bodies.containers import CONTAINER_TYPES


def _zero_normal_outputs(mlp: NumpyMLP) -> NumpyMLP:
    """The network with its last layer's normal outputs (columns 3:6) and their biases zeroed."""
    W, b = list(mlp.weights), list(mlp.biases)
    W[-1], b[-1] = W[-1].copy(), b[-1].copy()
    W[-1][:, 3:6] = 0.0
    b[-1][3:6] = 0.0
    return dataclasses.replace(mlp, weights=tuple(W), biases=tuple(b))


def point_correction_only(predictor: ContactPredictor) -> ContactPredictor:
    """`predictor` with its networks' normal corrections zeroed (TrainConfig.normal_correction
    False): the normal is the geometric estimate's wherever the networks answer."""
    expert = _zero_normal_outputs(predictor.expert) if predictor.expert is not None else None
    return dataclasses.replace(predictor, mlp=_zero_normal_outputs(predictor.mlp), expert=expert)


def train_default(out_dir=None, seed: int = 0, progress: bool = True, config: TrainConfig | None = None) -> dict:
    """Reproduces the shipped model from `seed`: labels the datasets, trains the
    improved predictor and the paper-faithful baseline, evaluates both, and writes to
    out_dir (default learned_contact/shipped): weights.npz, paper_weights.npz,
    config.json, metrics.json and report.md. Returns the metrics dict."""
    config = dataclasses.replace(config or TrainConfig(), seed=seed)
    out_dir = Path(out_dir) if out_dir is not None else SHIPPED_DIR
    t0 = time.perf_counter()
    data = default_datasets(config, progress=progress)
    t_labels = time.perf_counter() - t0
    g_tr, g_va = split_validation(data["general"], int(config.n_val_fraction * len(data["general"])))
    s_tr, s_va = split_validation(data["stacking"], int(config.n_val_fraction * len(data["stacking"])))
    pools = [(g_tr, g_va), (s_tr, s_va)]
    if "resting" in data:
        pools.append(split_validation(data["resting"], int(config.n_val_fraction * len(data["resting"]))))
    train, val = concat_datasets([t for t, _ in pools]), concat_datasets([v for _, v in pools])
    mlp, info = train_improved(train, val, config, progress=progress)
    sizes = np.array([CONTAINER_TYPES[t].size for t in config.types])
    meta = {"config": config.to_json(), "seed": seed, "train_info": {"best_val_loss": info["best_val_loss"]}}
    extra, expert_val = {}, ()
    if config.expert is not None:
        expert, expert_info, expert_val = train_expert(data, config, progress=progress)
        extra = {"expert": expert, "expert_domain": config.expert.domain()}
        meta["train_info"]["expert_best_val_loss"] = expert_info["best_val_loss"]
    # the network is fitted on config.types; it answers every ISO type and any box in the stated range
    predictor = ContactPredictor(mlp, answered_sizes(), meta, size_range=ANSWERED_SIZE_RANGE, **extra)
    if not config.normal_correction:
        predictor = point_correction_only(predictor)
    t_improved = time.perf_counter() - t0 - t_labels
    # paper-faithful baseline: general poses, sizes 10k / 6k / 50k
    pc = config.paper
    p_train = data["general"].subset(slice(0, pc.n_train))
    p_val = data["general"].subset(slice(len(data["general"]) - pc.n_val, len(data["general"])))
    p_test = data["general_test"].subset(slice(0, pc.n_test))
    paper, paper_info = train_paper(p_train, p_val, pc, seed=seed, progress=progress)
    t_paper = time.perf_counter() - t0 - t_labels - t_improved
    external = (data["general_test"], data["stacking_test"]) + ((data["resting_test"],) if "resting_test" in data else ())
    metrics = evaluate_models(predictor, paper, {"train": (g_tr, s_tr), "validation": (g_va, s_va, *expert_val),
                                                 "external": external},
                              paper_sets={"train": p_train, "validation": p_val, "external": p_test})
    metrics["paper_info"] = paper_info
    metrics["dropped_without_surface"] = {k: v.n_dropped for k, v in data.items()}
    metrics["wall_time_s"] = {"labels": t_labels, "improved": t_improved, "paper": t_paper,
                              "total": time.perf_counter() - t0}
    out_dir.mkdir(parents=True, exist_ok=True)
    predictor.save(out_dir / "weights.npz")
    paper_meta = {"config": config.to_json()["paper"], "types": list(config.types), "seed": seed,
                  "train_info": {"best_val_mse": paper_info["best_val_mse"]}}
    PaperPredictor(paper, sizes, paper_meta).save(out_dir / "paper_weights.npz")
    (out_dir / "config.json").write_text(json.dumps(config.to_json(), indent=2) + "\n")
    metrics["weights_sha256"] = weights_digest(out_dir / "weights.npz")
    write_report(metrics, out_dir)
    return metrics


def rescore_shipped(out_dir=None, *, progress: bool = True) -> dict:
    """Re-scores the shipped improved predictor with today's inference code, without
    retraining: the same labelled sets (cached) and splits as train_default's at the shipped
    seed, the weights as shipped; metrics.json's "improved" and "drake_point_contact" figures are
    replaced (everything else, the paper baseline included, is kept) and written to
    out_dir (default: the shipped folder itself) with report.md rendered again. For a change
    of the predictor's answer that leaves its networks as they are (e.g. Drake's face-on-face
    quadrature). Returns the new metrics dict."""
    out_dir = Path(out_dir) if out_dir is not None else SHIPPED_DIR
    metrics = json.loads((SHIPPED_DIR / "metrics.json").read_text())
    saved = json.loads((SHIPPED_DIR / "config.json").read_text())
    config = TrainConfig(seed=saved["seed"])
    default = json.loads(json.dumps(config.to_json()))  # tuples as lists, as saved
    if {**default, **saved, "expert": {**default["expert"], **(saved.get("expert") or {})}} != default:
        raise ValueError(f"{SHIPPED_DIR / 'config.json'}: not the default configuration at seed {saved['seed']}; "
                         "re-score it by retraining (train_default)")
    data = default_datasets(config, progress=progress)
    g_tr, g_va = split_validation(data["general"], int(config.n_val_fraction * len(data["general"])))
    s_tr, s_va = split_validation(data["stacking"], int(config.n_val_fraction * len(data["stacking"])))
    expert_val = tuple(split_validation(data[k], int(config.n_val_fraction * len(data[k])))[1] for k in EXPERT_SETS if k in data)
    external = (data["general_test"], data["stacking_test"]) + ((data["resting_test"],) if "resting_test" in data else ())
    predictor = load_weights("improved")
    fresh = evaluate_models(predictor, None, {"train": (g_tr, s_tr), "validation": (g_va, s_va, *expert_val),
                                              "external": external}, paper_sets={})
    metrics["improved"] = fresh["improved"]
    metrics["drake_point_contact"] = fresh["drake_point_contact"]  # the same labels and error measures
    metrics["weights_sha256"] = weights_digest(SHIPPED_DIR / "weights.npz")
    out_dir.mkdir(parents=True, exist_ok=True)
    write_report(metrics, out_dir)
    return metrics


def evaluate_models(predictor: ContactPredictor, paper: NumpyMLP, sets: dict, paper_sets: dict) -> dict:
    """Figures of both models. sets: split -> (general Dataset, stacking Dataset) for the
    improved model; paper_sets: split -> general Dataset for the paper model."""
    out = {"improved": {}, "paper": {}}
    for split, group in sets.items():
        for ds in group:
            point, normal = predictor.predict(ds.p_AB, ds.R_AB, size_A=ds.size_A, size_B=ds.size_B)
            out["improved"][f"{split}/{ds.distribution}"] = evaluate(point, normal, ds)
    out["drake_point_contact"] = {}
    for ds in sets.get("external", ()):  # Drake's point-contact answer against the same labels
        ok = np.all(np.isfinite(ds.pp_point), axis=1) & np.all(np.isfinite(ds.pp_normal), axis=1)
        sub = ds.subset(ok)
        out["drake_point_contact"][f"external/{ds.distribution}"] = evaluate(sub.pp_point, sub.pp_normal, sub)
    for split, ds in paper_sets.items():
        out["paper"][split] = {"n": len(ds), "paper_table": paper_table(predict_paper(paper, ds.p_AB, ds.R_AB), paper_targets(ds))}
    return out


def main(argv=None) -> None:
    """python -m learned_contact.training.train [--out DIR] [--seed N] [--recipe resting|support_expert] [--quiet]"""
    import argparse

    parser = argparse.ArgumentParser(description="Reproduce learned_contact's shipped model from a seed.")
    parser.add_argument("--out", default=None, help="output folder (default learned_contact/shipped)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--recipe", choices=("shipped", "resting", "support_expert"), default="shipped",
                        help="resting: the resting-regime candidate (RESTING_RECIPE; needs --out); support_expert: "
                             "the support candidate expert (SUPPORT_EXPERT) beside the shipped main network, only weights.npz "
                             "written (needs --out)")
    parser.add_argument("--quiet", action="store_true", help="no progress bars")
    parser.add_argument("--rescore", action="store_true",
                        help="re-score the shipped weights with today's inference code (metrics.json, report.md), "
                             "no training")
    args = parser.parse_args(argv)
    if args.rescore:
        rescore_shipped(args.out, progress=not args.quiet)
        return
    if args.recipe != "shipped" and args.out is None:
        parser.error(f"--recipe {args.recipe} needs --out DIR (it would overwrite the shipped model)")
    if args.recipe == "support_expert":
        t0 = time.perf_counter()
        base = load_weights("improved", compiled=False)
        predictor, info = refit_expert(base, TrainConfig(seed=args.seed, expert=SUPPORT_EXPERT), progress=not args.quiet)
        path = predictor.save(Path(args.out) / "weights.npz")
        print(json.dumps({"weights": str(path), "expert_best_val_loss": info["best_val_loss"],
                          "wall_time_s": time.perf_counter() - t0}))
        return
    config = TrainConfig(**RESTING_RECIPE) if args.recipe == "resting" else None
    metrics = train_default(args.out, seed=args.seed, progress=not args.quiet, config=config)
    print(json.dumps(metrics["wall_time_s"]))


if __name__ == "__main__":
    main()
