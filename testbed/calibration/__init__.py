"""Calibrating Drake's contact parameters against real cube tosses (`testbed calibrate`).

One job per module: data (the toss file), rollout (one Drake plant per parameter set,
open-loop rollouts and the error metric), split (train/test keeping duplicates together),
evaluate (parallel rollouts), fit (the optimiser), params_file (parameters <-> a scene
fragment), report (metrics.json, plots), workflow (the command's two workflows).
README.md beside this file holds the shipped parameters' figures.
"""
