"""Accuracy gates of the learned predictor on the shipped model, on held-out poses made here.

The held-out poses use sampling seeds that training never uses (training uses
10 * seed + 1 and + 2) and include poses outside the training distribution (steeper
tilts, deeper overlaps: learned_contact/evaluation/gates.py). Every gate must be one that a simple
alternative fails: the predictor's own geometric estimate (network zeroed) or Drake's
point contact. Figures: see learned_contact/shipped/report.md.
"""

import numpy as np
import pytest

from learned_contact import load_predictor
from learned_contact.data.labels import make_dataset
from learned_contact.evaluation.gates import KNOWN_LIMITS, REPORTED, THRESHOLDS, GeometricPrior, answer_figures, gate_figures, held_out, outside_training
from learned_contact.evaluation.metrics import paper_table
from learned_contact.predictors.paper import predict_paper
from learned_contact.training.paper import PaperConfig, paper_targets, train_paper

GATE_SEED = 98_765  # sampling seeds 987_655 / 987_656 / 987_657, never used in training


@pytest.fixture(scope="module")
def data():
    return held_out(GATE_SEED)


@pytest.fixture(scope="module")
def figures(data):
    return gate_figures(load_predictor(), data)


@pytest.fixture(scope="module")
def alternatives(data):
    """Figures of the simple alternatives on the same poses."""
    prior = gate_figures(GeometricPrior(), data)
    ok = {d: np.all(np.isfinite(ds.pp_point), axis=1) & np.all(np.isfinite(ds.pp_normal), axis=1) for d, ds in data.items()}
    sub = {d: ds.subset(ok[d]) for d, ds in data.items()}
    point_contact = answer_figures({d: (ds.pp_point, ds.pp_normal) for d, ds in sub.items()}, sub)
    return {"geometric prior": prior, "Drake point contact": point_contact}


@pytest.mark.parametrize("name", list(THRESHOLDS))
def test_accuracy_gate(figures, name):
    limit, unit = THRESHOLDS[name]
    assert figures[name] <= limit, f"{name}: {figures[name]:.4g} {unit} > {limit} {unit}"


@pytest.mark.parametrize("name", list(THRESHOLDS))
def test_every_gate_is_failed_by_a_simple_alternative(alternatives, name):
    """A gate the network's absence (or Drake's point contact) also passes guards nothing."""
    limit, _ = THRESHOLDS[name]
    failing = [k for k, f in alternatives.items() if not f[name] <= limit]
    assert failing, {k: f[name] for k, f in alternatives.items()}


@pytest.mark.parametrize("name", list(KNOWN_LIMITS))
def test_known_limit_is_pinned(figures, name):
    """Out of reach today: the figure must stay in its pinned band (worse fails; reaching
    the target fails too, so the pin is updated and the gate becomes a plain one)."""
    target, pinned, (low, high), why = KNOWN_LIMITS[name]
    value = figures[name]
    assert value > target, f"{name} = {value:.3g} now meets its target {target}: make it a gate"
    assert low * pinned <= value <= high * pinned, f"{name} = {value:.3g} left the band around {pinned}"
    pytest.xfail(f"{name}: measured {value:.3g} (target <= {target}): {why}")


def test_held_out_includes_poses_outside_the_training_distribution(data):
    outside = data["outside"]
    assert len(outside) >= 200  # of 400 drawn; measured 277-290 over four seeds
    assert np.all(outside_training(outside))
    assert np.any(outside.depth > 0.03) and np.any(~(outside.depth > 0.03))  # both kinds of "outside"
    # the training distribution itself stays inside (the test of outside_training's definition)
    assert not np.any(outside_training(data["stacking"]) & (data["stacking"].depth > 0.03))


def test_reported_figures_exist(figures):
    for name in REPORTED:
        assert np.isfinite(figures[name]) and np.isfinite(figures[f"{name} vs prior"] if figures[f"prior: {name}"] > 0 else 0.0)


# Stated MAE of the paper-faithful baseline at this reduced size (2000 train / 1000
# validation poses, 2 restarts, <= 40 epochs), on the 400 held-out general poses.
# Measured: 0.260 rad (training seed 0) on GATE_SEED poses; 0.275 and 0.281 (training
# seeds 0, 1) on another held-out set; a constant predictor scores about 0.50.
# The paper's own Table 2 external MAE is 0.4523 rad.
PAPER_BASELINE_MAE = 0.35


@pytest.mark.torch
def test_paper_baseline_trains_to_stated_mae(data):
    general = data["general"]
    train = make_dataset("general", 2000, 987_653, progress=False, use_cache=False)
    val = make_dataset("general", 1000, 987_654, progress=False, use_cache=False)
    config = PaperConfig(n_train=len(train), n_val=len(val), restarts=2, max_epochs=40, patience=8)
    mlp, info = train_paper(train, val, config, seed=0, progress=False)
    assert len(info["val_mse_per_restart"]) == 2
    y_true = paper_targets(general)
    mae = paper_table(predict_paper(mlp, general.p_AB, general.R_AB), y_true)["mean"]["MAE"]
    constant = paper_table(np.broadcast_to(paper_targets(train).mean(0), y_true.shape), y_true)["mean"]["MAE"]
    assert mae <= PAPER_BASELINE_MAE, f"paper baseline MAE {mae:.4f} rad (constant predictor {constant:.4f})"
    assert mae < 0.8 * constant


def test_the_wider_resting_sets_hold_overhangs_and_their_exactly_level_poses(data):
    """"resting_wider" reaches B's centre metres along A's x and yaws beyond the resting
    expert's 2-3 deg; "resting_wider_level" is exactly its level poses (about half)."""
    wider, level = data["resting_wider"], data["resting_wider_level"]
    assert np.abs(wider.p_AB[:, 0]).max() > 2.5 and np.degrees(np.abs(np.arcsin(wider.R_AB[:, 1, 0]))).max() > 5.0
    assert 0.35 < len(level) / len(wider) < 0.65
    assert np.all(level.R_AB[:, 0, 2] == 0.0) and np.all(level.R_AB[:, 1, 2] == 0.0)
