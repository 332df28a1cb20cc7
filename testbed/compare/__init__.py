"""Twin runs: one scene under Drake's contact and under the learned closed loop.

    from testbed.compare import compare_scene
    figures = compare_scene("five_stack", predictor="improved", out_dir="out/")

runs.py simulates the variants and records their trajectories; metrics.py turns two
trajectories into the figures of compare.json; artifacts.py writes the time series,
the divergence plot and the ghost replay. Nothing here imports torch.
"""

from testbed.compare.twin import compare_predictors, compare_scene

__all__ = ["compare_predictors", "compare_scene"]
