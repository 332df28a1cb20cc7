"""Datasets: pose distributions (sampling.py), Drake's static hydroelastic labels
(labels.py, needs Drake) and their on-disk cache (cache.py)."""
