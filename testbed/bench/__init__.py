"""`testbed bench`: any set of predictors judged side by side, the same way.

  model.py     resolve(spec): the model loaded once, with the container sizes it declares (every section takes it)
  accuracy.py  held-out pose sets (the gates' and a resting set; a model's own sizes' when it declares fewer),
               figures and ratios to the prior
  cost.py      cost per query (one pair per call, batched, first call) against Drake and the shipped predictor
  yard_budget.py  pairs each predictor answers within a 1 ms step beside the host engine's own step
  scenes.py    in-scene (open loop) accuracy with its gates and closed-loop verdicts in the shipped scenes its sizes allow
  run.py       bench(specs, quick, out_dir): the Python API (the shipped predictors beside a user's model); the
               leaderboard and one verdict per predictor
  report.py    bench.json, summary.md, index.html
  first_screen.py  the report's first screen: one verdict table (costs in us, then ratios to Drake's point-pair query)
  plots.py     accuracy against cost and per pose set, every model and the Drake reference drawn
"""

from testbed.bench.run import bench

__all__ = ["bench"]
