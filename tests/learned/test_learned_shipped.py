"""The shipped model's files agree with each other and with the training code:
metrics.json is what the shipped weights score, report.md is rendered from metrics.json,
and `testbed train --seed 0` (slow) reproduces the shipped weights and figures."""

import json

import numpy as np
import pytest

from learned_contact import load_predictor
from learned_contact.data.labels import make_dataset
from learned_contact.evaluation.metrics import evaluate
from learned_contact.evaluation.report import render_markdown
from learned_contact.predictors.improved import SHIPPED_DIR
from learned_contact.training.config import SEED_TEST, TrainConfig

METRICS = json.loads((SHIPPED_DIR / "metrics.json").read_text())


def test_report_md_is_rendered_from_metrics_json():
    assert (SHIPPED_DIR / "report.md").read_text() == render_markdown(METRICS) + "\n"


def test_metrics_json_is_what_the_shipped_weights_score():
    """Re-labels the external stacking set of the shipped config (10 000 poses, seed
    10 * 0 + SEED_TEST) and scores the shipped weights: the stored figures must come
    back to 1e-9 (relative), i.e. metrics.json belongs to these weights."""
    config = TrainConfig(**{k: v for k, v in json.loads((SHIPPED_DIR / "config.json").read_text()).items()
                            if k in ("seed", "n_test_stacking")})
    ds = make_dataset("stacking", config.n_test_stacking, 10 * config.seed + SEED_TEST, progress=False)
    point, normal = load_predictor().predict(ds.p_AB, ds.R_AB, size_A=ds.size_A, size_B=ds.size_B)
    fresh = evaluate(point, normal, ds)
    stored = METRICS["improved"]["external/stacking"]
    for group in ("point_m", "normal_deg"):
        for stat in ("median", "p95", "p99", "max"):
            assert fresh[group][stat] == pytest.approx(stored[group][stat], rel=1e-9), (group, stat)
    assert fresh["n"] == stored["n"]


@pytest.mark.slow
@pytest.mark.torch
def test_train_seed_0_reproduces_the_shipped_weights(tmp_path):
    """`testbed train --seed 0` end to end into a scratch folder (labels, both networks,
    evaluation). The main network's weights and its external figures match the shipped ones:
    not bitwise (the float32 summation order of torch's CPU kernels; measured: weights within
    5.9e-5, figures within 2.5e-6 relative), so the tolerances are 2e-4 and 1e-4, far below
    what a changed seed or data set gives (weights differ at 1e-1). The resting expert (160
    epochs on micrometre overlaps) follows another path on some CPUs from the same seed and
    data: on 2026-12-02's machine, at this session's base commit as at its end, its weights
    differ by up to 0.06 while the main network matched to 1e-5 relative. So the expert is
    held to the shipped figures it produces instead: on the external resting set, the learned
    pipeline's point and normal median and p95 (the expert answers there beneath the
    quadrature) within 15 % of the shipped expert's (measured: 0.97-1.05x), and its gate
    (expert_domain) exactly."""
    from learned_contact.training.train import train_default

    metrics = train_default(tmp_path, seed=0, progress=False)
    mine, shipped = load_predictor(tmp_path / "weights.npz"), load_predictor()
    for a, b in zip(mine.mlp.weights, shipped.mlp.weights):
        np.testing.assert_allclose(a, b, rtol=0, atol=2e-4)
    np.testing.assert_array_equal(mine.expert_domain, shipped.expert_domain)
    for key in ("median", "p95"):
        assert metrics["improved"]["external/stacking"]["point_m"][key] == pytest.approx(
            METRICS["improved"]["external/stacking"]["point_m"][key], rel=1e-4)
    # the expert shapes the learned pipeline beneath the quadrature (which answers every resting pose
    # since format_version 3): its own answer on the external resting set, against the shipped expert's
    from learned_contact.evaluation.metrics import point_normal_errors
    from testbed.geometry.boxes import sat_normal

    ds = make_dataset("resting", TrainConfig().n_test_resting, 10 * 0 + SEED_TEST, progress=False)
    h_A, h_B = 0.5 * ds.size_A, 0.5 * ds.size_B
    sat_n, depth, _ = sat_normal(ds.p_AB, ds.R_AB, h_A, h_B)
    figures = [point_normal_errors(*pred.with_compiled(False)._learned(ds.p_AB, ds.R_AB, h_A, h_B, sat_n, depth), ds)
               for pred in (mine, shipped)]
    for (e_mine, e_shipped), what in zip(zip(*figures), ("point", "normal")):
        for q in (50, 95):
            assert np.percentile(e_mine, q) == pytest.approx(np.percentile(e_shipped, q), rel=0.15), (what, q)
