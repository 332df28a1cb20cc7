"""Judging predictors: the accuracy gates (gates.py) and their metrics (metrics.py), the
shipped model's report (report.py), what a query costs (cost.py) and the benchmark script
(benchmark.py: `python -m learned_contact.evaluation.benchmark`)."""
