"""Training the shipped predictors (train.py; `testbed train`) and the paper's MLP
(paper.py): needs torch (the `train` extra)."""
