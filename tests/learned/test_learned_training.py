"""Training reproduces from a seed (slow: trains small models end to end)."""

import numpy as np
import pytest

from learned_contact import load_predictor
from learned_contact.training.config import ExpertConfig, TrainConfig
from learned_contact.training.paper import PaperConfig
from learned_contact.training.train import train_default

pytestmark = pytest.mark.torch  # trains with torch (tests/conftest.py: skipped where it is not installed)

TINY = TrainConfig(n_general=1500, n_stacking=1500, n_test_general=300, n_test_stacking=300, epochs=3,
                   hidden=(32, 32), paper=PaperConfig(n_train=500, n_val=300, n_test=300, restarts=1, max_epochs=3),
                   expert=ExpertConfig(n_resting=500, n_resting_wide=500, epochs=3), n_test_resting=300)


@pytest.mark.slow
def test_train_default_is_reproducible_from_seed(tmp_path, monkeypatch):
    monkeypatch.setenv("TESTBED_CACHE", str(tmp_path / "cache"))
    m1 = train_default(tmp_path / "a", seed=3, progress=False, config=TINY)
    m2 = train_default(tmp_path / "b", seed=3, progress=False, config=TINY)
    a, b = load_predictor(tmp_path / "a" / "weights.npz"), load_predictor(tmp_path / "b" / "weights.npz")
    for wa, wb in zip(a.mlp.weights + a.expert.weights, b.mlp.weights + b.expert.weights):
        np.testing.assert_array_equal(wa, wb)
    # the expert is its own network, trained on resting poses only
    assert not np.allclose(a.expert.weights[1], a.mlp.weights[1])
    assert m1["improved"]["external/resting"]["point_m"]["n"] == 300
    assert m1["improved"]["external/stacking"]["point_m"] == m2["improved"]["external/stacking"]["point_m"]
    for name in ("weights.npz", "paper_weights.npz", "config.json", "metrics.json", "report.md"):
        assert (tmp_path / "a" / name).is_file()
    # the evaluation ran on the external sets
    assert np.isfinite(m1["improved"]["external/general"]["normal_deg"]["median"])


@pytest.mark.slow
def test_the_resting_recipe_adds_resting_poses_to_the_training_pool(tmp_path, monkeypatch):
    """TrainConfig.n_resting (RESTING_RECIPE) labels that many
    "resting" poses and trains on them: the run records them and its weights differ from
    the same run without them (same seed, same other data)."""
    import dataclasses
    import json

    from learned_contact.training.config import RESTING_RECIPE

    assert RESTING_RECIPE["n_resting"] > 0 and TrainConfig().n_resting == 0  # the shipped recipe has none
    monkeypatch.setenv("TESTBED_CACHE", str(tmp_path / "cache"))
    m = train_default(tmp_path / "r", seed=3, progress=False, config=dataclasses.replace(TINY, n_resting=400))
    assert "resting" in m["dropped_without_surface"]
    assert json.loads((tmp_path / "r" / "config.json").read_text())["n_resting"] == 400
    train_default(tmp_path / "plain", seed=3, progress=False, config=TINY)
    a, b = load_predictor(tmp_path / "r" / "weights.npz"), load_predictor(tmp_path / "plain" / "weights.npz")
    assert not np.allclose(a.mlp.weights[0], b.mlp.weights[0])


@pytest.mark.slow
def test_refit_expert_keeps_the_main_network_and_takes_the_support_gate(tmp_path, monkeypatch):
    """training.refit_expert: a new expert on the wider resting sets beside the shipped
    main network, unchanged bit for bit; with gate="support" its bounds are support_domain() and
    it saves as format_version 3."""
    from learned_contact.training.config import support_domain
    from learned_contact.training.loop import refit_expert

    monkeypatch.setenv("TESTBED_CACHE", str(tmp_path / "cache"))
    shipped = load_predictor(compiled=False)
    ex = ExpertConfig(n_resting=300, n_resting_wide=0, n_resting_level=0, n_resting_wider=300, n_resting_support=300,
                      narrow_repeat=2, epochs=2, gate="support")
    new, info = refit_expert(shipped, TrainConfig(expert=ex), progress=False)
    for a, b in zip(new.mlp.weights + new.mlp.biases, shipped.mlp.weights + shipped.mlp.biases):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(new.expert_domain, support_domain())
    assert new.meta["config"]["expert"]["n_resting_support"] == 300 and len(info["val_loss_history"]) == 2
    with np.load(new.save(tmp_path / "w.npz")) as z:
        assert int(z["format_version"]) == 3
