"""Training the shipped predictors (train.py on config.py, datasets.py and loop.py; `testbed
train`) and the paper's MLP (paper.py): needs torch (the `train` extra)."""
