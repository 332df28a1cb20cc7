"""Accuracy gates of issue 3 on the shipped model, on held-out poses made here.

The held-out poses use sampling seeds that training never uses (training uses
10 * seed + 1 and + 2). Figures: see learned_contact/shipped/report.md.
"""

import numpy as np
import pytest

from learned_contact import load_predictor
from learned_contact.gates import THRESHOLDS, gate_figures, held_out
from learned_contact.labels import make_dataset
from learned_contact.metrics import paper_table
from learned_contact.paper_mlp import PaperConfig, paper_targets, predict_paper, train_paper

GATE_SEED = 98_765  # sampling seeds 987_655 / 987_656, never used in training


@pytest.fixture(scope="module")
def data():
    return held_out(GATE_SEED)


@pytest.fixture(scope="module")
def figures(data):
    return gate_figures(load_predictor(), data)


@pytest.mark.parametrize("name", list(THRESHOLDS))
def test_accuracy_gate(figures, name):
    limit, unit = THRESHOLDS[name]
    assert figures[name] <= limit, f"{name}: {figures[name]:.4g} {unit} > {limit} {unit}"


def test_gate_thresholds_are_the_issue_s():
    assert {k: v[0] for k, v in THRESHOLDS.items()} == {
        "stacking point error median": 0.03, "stacking point error p95": 0.15, "stacking normal error p95": 1.0,
        "general normal error median": 3.0, "general MAE on the paper's 4 outputs": 0.15}


# Stated MAE of the paper-faithful baseline at this reduced size (2000 train / 1000
# validation poses, 2 restarts, <= 40 epochs), on the 400 held-out general poses.
# Measured: 0.260 rad (training seed 0) on GATE_SEED poses; 0.275 and 0.281 (training
# seeds 0, 1) on another held-out set; a constant predictor scores about 0.50.
# The paper's own Table 2 external MAE is 0.4523 rad.
PAPER_BASELINE_MAE = 0.35


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
