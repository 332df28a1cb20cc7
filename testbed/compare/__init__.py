"""Comparisons against one reference run: Drake's truth, then candidates (engines, with
their contact parameters or predictors) from the same initial state.

    from testbed.compare import Candidate, compare_candidates
    figures = compare_candidates(scenario, [Candidate("learned", predictor="improved"), Candidate.point()],
                                 out_dir="out/")

candidates.py names what runs (Candidate); run_candidates.py runs the reference once and
every candidate, judges the learned ones and writes compare.json; runs.py holds the twin
run's Drake variants; metrics.py turns two trajectories into the figures; contact_figures.py
compares contact rows; external_work.py the external actors' work and the energy net of it;
artifacts.py writes the time series, the divergence plot and the ghost replay; report.py the
report (report.html, report.md: the verdicts and figures first) and report_plots.py its plots
(divergence.png, error_map.png); printed.py the lines `testbed compare` prints; twin.py keeps compare_scene,
compare_predictors and compare_engine as wrappers; verdict.py turns the closed-loop and
in-scene gates (testbed/gates) into compare's verdict, passed to compare_candidates as its
`judge` by the callers that want one. Nothing here imports torch.
"""

from testbed.compare.candidates import Candidate
from testbed.compare.run_candidates import compare_candidates
from testbed.compare.twin import compare_engine, compare_predictors, compare_scene

__all__ = ["Candidate", "compare_candidates", "compare_engine", "compare_predictors", "compare_scene"]
