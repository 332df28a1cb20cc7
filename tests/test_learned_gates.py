"""Accuracy gates of issue 3 on the shipped model, on held-out poses made here.

The held-out poses use sampling seeds that training never uses (training uses
10 * seed + 1 and + 2). Figures: see learned_contact/shipped/report.md.
"""

import numpy as np
import pytest

from learned_contact import load_predictor
from learned_contact.encodings import octant_signs, paper_outputs
from learned_contact.labels import make_dataset
from learned_contact.metrics import paper_table, point_normal_errors
from learned_contact.paper_mlp import PaperConfig, paper_targets, predict_paper, train_paper

N_HELD_OUT = 400


@pytest.fixture(scope="module")
def pred():
    return load_predictor()


@pytest.fixture(scope="module")
def stacking():
    return make_dataset("stacking", N_HELD_OUT, 987_651, progress=False, use_cache=False)


@pytest.fixture(scope="module")
def general():
    return make_dataset("general", N_HELD_OUT, 987_652, progress=False, use_cache=False)


def _errors(pred, ds):
    point, normal = pred.predict(ds.p_AB, ds.R_AB, size_A=ds.size_A, size_B=ds.size_B)
    return point, normal, *point_normal_errors(point, normal, ds)


def test_stacking_gates(pred, stacking):
    _, _, e_point, e_normal = _errors(pred, stacking)
    assert np.median(e_point) <= 0.03, f"median point error {np.median(e_point):.4f} m"
    assert np.percentile(e_point, 95) <= 0.15, f"p95 point error {np.percentile(e_point, 95):.4f} m"
    assert np.percentile(e_normal, 95) <= 1.0, f"p95 normal error {np.percentile(e_normal, 95):.3f} deg"


def test_general_gates(pred, general):
    point, normal, _, e_normal = _errors(pred, general)
    assert np.median(e_normal) <= 3.0, f"median normal error {np.median(e_normal):.3f} deg"
    S = octant_signs(general.p_AB)
    table = paper_table(paper_outputs(point, normal, S), paper_outputs(general.cop, general.normal, S))
    assert table["mean"]["MAE"] <= 0.15, f"MAE on the paper's outputs {table['mean']['MAE']:.4f} rad"


# Measured with this reduced setting: external MAE ~0.33 rad (2 restarts, 2000/1000);
# the gate leaves room for seeds, and a constant predictor scores ~0.55 rad.
PAPER_BASELINE_MAE = 0.42


def test_paper_baseline_trains_to_stated_mae(general):
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
