"""Accuracy gates of the learned predictor, evaluated on held-out poses made on the spot.

Held-out sets (sampling seeds 10 * seed + 5, + 6, + 7, + 8, + 9; training uses + 1 and + 2):
- "stacking", "general": the training distributions, re-drawn from unused seeds;
- "outside": poses OUTSIDE the training sampler's distribution: stacking landings
  drawn with roll and pitch up to 10 deg (training: 5 deg) and penetration up to 5 cm
  (training: 3 cm), of which only the poses beyond a training range are kept (a steeper
  tilt or a deeper overlap); all of them lie in the predictor's answered domain
  (DOMAIN_DEPTH).
- "resting": where shipped stacks sit at the 1e9 Pa modulus (sampling's
  "resting" distribution: overlap 5 um to 0.5 mm log-uniform, roll and pitch within
  0.05 deg, yaw within 2 deg, offsets up to 0.4 m). `resting_set(seed, n)` draws it
  alone (the bench's resting set).
- "resting_wider": where landings and overhangs leave a box resting (sampling's
  "resting_wider": yaw within 6 deg, B's centre up to 3 m off A's along A's x and 0.6 m along
  y, all 20 ft / 40 ft pairs, overlap 5 um to 0.5 mm, half of the poses exactly level, the
  others with roll and pitch within 0.05 deg). `resting_wider_set(seed, n)` draws it alone;
  its exactly level poses are "resting_wider_level" (the same labels).
On both resting sets, and wherever two faces meet (stacks tilted up to 2 deg for the
normal, 20 deg for the point), the predictor answers with the exact integral of Drake's
face-on-face pressure in closed form (learned_contact.model.quadrature), which is why their
bounds are nanometres to micrometres: the residue is the slab model of Drake's tetrahedra, not a fit.
Labels are the exact centre of pressure (testbed.contact.surfaces); every point figure is reported
beside the one-point rule's distance from it on the same poses ("<set> truth gap ...").

Two kinds of gate, and why: absolute bounds (the issue-3 thresholds) say the answer is
good enough for a crane simulator; "vs prior" bounds say the network earns its place.
The predictor's geometric estimate alone (its network zeroed: `geometric_prior`) and
Drake's point contact pass two of the absolute bounds (general normal median, general
MAE), so those alone could not catch a network that learned nothing; every "vs prior"
gate is a ratio of the predictor's figure to the prior's on the same poses, and the
prior scores 1.0 on each, so it fails them by construction of the bound (< 1).
tests/learned/test_learned_gates.py checks that every gate is failed by at least one of the
simple alternatives (prior, Drake point contact).

`evaluate_gates(seed)` returns {"gates": [{name, passed, value, threshold, unit,
description}], "figures": ...}; the pytest gates and `testbed validate` both use it.
"""

from __future__ import annotations

import numpy as np

from learned_contact.data.labels import make_dataset
from learned_contact.data.sampling import DEFAULT_TYPES
from learned_contact.evaluation.metrics import paper_table, point_normal_errors
from learned_contact.model.encodings import canonicalise, features, octant_signs, paper_outputs
from learned_contact.sources import load_predictor
from testbed.contact.surfaces import EXACT_LABEL_TOLERANCE_M, EXACT_NORMAL_TOLERANCE_DEG
from testbed.gates import KnownLimit, pinned

N_HELD_OUT = 400
OUTSIDE_RANGES = {"max_tilt_deg": 10.0, "max_depth": 0.05}  # training: 5 deg, 0.03 m
TRAINING_TILT_DEG, TRAINING_DEPTH = 5.0, 0.03
# Every gate is failed by a simple alternative (tests/learned/test_learned_gates.py): the prior
# (the continuum geometric estimate: the network zeroed and no closed form) or Drake's point
# contact. The labels are the exact centre of pressure (LABEL_VERSION 3), against which the prior
# is a strong baseline (it is a linear foundation's exact integral over the clipped patch: 0.9-1.0
# mm median on stacking poses, 1.8 mm on general ones), so the "vs prior" bounds say where the
# predictor is better than that and, on general poses, that it is never worse. Figures measured on
# held-out seeds 0-4 and 98765 (400 poses per set, 2026-12-03) are in the comments, with the issue
# targets; each bound is the target or leaves room for that seed-to-seed spread. Where faces meet the
# predictor answers with the exact integral of Drake's face-on-face pressure in closed form
# (learned_contact.model.quadrature), so most stacking and resting figures are that closed form's.
THRESHOLDS = {
    # stacking (training-like): targets 1 mm median, 5 mm p95, 0.5 deg normal p95
    "stacking point error median": (0.0006, "m"),  # 0.18-0.24 mm (prior 0.9-1.0 mm)
    "stacking point error p95": (0.005, "m"),  # 1.5-3.4 mm (point contact: metres)
    # target 0.5 deg: met on 5 of 6 seeds (seed 1: 0.51 deg); prior 1.4-1.6 deg
    "stacking normal error p95": (0.6, "deg"),  # 0.26-0.51 deg
    # the predictor must improve on its own continuum estimate (ratios: the prior scores 1)
    "stacking point error median vs prior": (0.35, "x"),  # 0.18-0.25
    # general: targets 2 mm median, 10 mm p95, and never worse than the geometric estimate
    "general point error median": (0.002, "m"),  # 1.5-1.8 mm (prior 1.8-1.9 mm: passes; point contact fails)
    "general point error p95": (0.010, "m"),  # 7.0-9.4 mm
    # a tie, not a gain: 0.84-0.99 (median) and 0.75-0.84 on seeds 0-2 and 98765 but 1.01 and 1.07
    # on seeds 3 and 4 (p95); the networks trained on one-point labels scored 1.8 and 2.0 here
    "general point error median vs prior": (1.0, "x"),
    "general point error p95 vs prior": (1.0, "x"),
    "general MAE on the paper's 4 outputs vs prior": (1.0, "x"),  # 0.50-0.89
    # outside the training distribution: still bounded, still better than the prior at the median
    "outside point error median": (0.002, "m"),  # 0.94-1.16 mm (prior 1.4-1.6 mm)
    "outside point error median vs prior": (0.85, "x"),  # 0.61-0.74
    # the outside set is small (about 290 poses) and its normal tail heavy: judged against the prior
    "outside normal error p95 vs prior": (0.6, "x"),  # 0.20-0.53
    # resting (where shipped stacks sit; mostly tilted up to 0.05 deg): targets 0.05 mm median, 0.5 mm p95
    "resting point error median": (1e-7, "m"),  # 12-14 nm (prior 5.4 um; point contact 9-10 cm)
    "resting point error p95": (1e-6, "m"),  # 0.12-0.16 um (prior 39 um)
    "resting point error p95 vs prior": (0.01, "x"),  # 0.0031-0.0038
    # the normal cannot be an absolute gate: the prior (0.041-0.044 deg) passes any sensible bound
    "resting normal error p95 vs prior": (0.002, "x"),  # 0.00057-0.00068 (2.6-2.8e-5 deg)
    # wider resting poses: yaw within 6 deg, B's centre up to 3 m x 0.6 m off A's (overhangs)
    "resting_wider point error median": (1e-7, "m"),  # 1-3 nm (prior 1.0 um)
    "resting_wider point error p95": (1e-6, "m"),  # 76-96 nm (prior 32 um)
    "resting_wider normal error p95 vs prior": (0.002, "x"),  # 0.00058-0.00075 (2e-5 deg; prior 0.032-0.038)
    "resting_wider_level point error p95": (1e-7, "m"),  # 5-7 nm (prior 4.1 um; point contact fails)
}
# Targets out of reach, pinned like the stress suite's expected failures: the gate holds
# while the figure stays in the band (factors of the pinned figure), so a predictor that
# gets worse fails it, and one that gets much better says the pin is stale.
# name -> (target, pinned figure, (low, high) band factors, why).
KNOWN_LIMITS: dict = {
    "outside point error p95 vs prior": (
        1.0, 1.075, (0.8, 1.25),
        "beyond the training ranges (5-10 deg of tilt, 3-5 cm deep) the tail comes from the face-on-face closed "
        "form's edge strips (a 45 deg strip model of the side faces' tetrahedra, least exact on deep tilted "
        "contacts), not from a network: 0.89-1.20x the geometric estimate's p95 over seeds 0-4 and 98765 "
        "(1.075 on the gates' test seed)"),
}
LIMIT_UNITS = {"vs prior": "x", "normal": "deg"}  # unit of a KNOWN_LIMITS figure by its name, else "m"
# Reported, not gated: where the geometric estimate is already exact (the normal of a
# vertex-face contact), the network can only lose; these figures show by how much.
REPORTED = ("general normal error median", "general normal error p95", "stacking normal error median",
            "outside normal error p95",
            "resting point error p99", "resting normal error median", "resting normal error p95",
            "resting_wider point error p99", "resting_wider normal error median", "resting_wider normal error p95",
            "resting_wider_level point error median")


def held_out(seed: int, n: int = N_HELD_OUT, *, workers: int = 2, progress: bool = False,
             types=DEFAULT_TYPES) -> dict:
    """{"stacking", "general", "outside", "resting", "resting_wider", "resting_wider_level": Dataset} of
    held-out poses (not cached; "resting_wider_level": the exactly level poses of "resting_wider").
    types: the container types whose ordered pairs are drawn (learned_contact.data.sampling.sample;
    e.g. sampling.types_of_sizes(predictor.supported_sizes) for a model declaring fewer sizes): n
    proposals per set within those pairs; the default draws the gates' own poses."""
    data = {d: make_dataset(d, n, 10 * seed + k, types=types, workers=workers, progress=progress, use_cache=False)
            for d, k in (("stacking", 5), ("general", 6))}
    wide = make_dataset("stacking", n, 10 * seed + 7, types=types, workers=workers, progress=progress,
                        use_cache=False, **OUTSIDE_RANGES)
    data["outside"] = wide.subset(outside_training(wide))
    data["resting"] = resting_set(seed, n, workers=workers, progress=progress, types=types)
    data["resting_wider"] = resting_wider_set(seed, n, workers=workers, progress=progress, types=types)
    data["resting_wider_level"] = data["resting_wider"].subset(exactly_level(data["resting_wider"]))
    return data


def exactly_level(ds) -> np.ndarray:
    """(n,) bool: poses of a Dataset whose B's z axis is A's z to the last bit (roll = pitch = 0)."""
    return (ds.R_AB[:, 0, 2] == 0.0) & (ds.R_AB[:, 1, 2] == 0.0)


def resting_wider_set(seed: int, n: int = N_HELD_OUT, *, workers: int = 2, progress: bool = False,
                      types=DEFAULT_TYPES):
    """The held-out "resting_wider" Dataset (sampling seed 10 * seed + 9, not cached): n
    proposals of sampling's "resting_wider" distribution over `types` (held_out), labelled by Drake."""
    return make_dataset("resting_wider", n, 10 * seed + 9, types=types, workers=workers, progress=progress,
                        use_cache=False)


def resting_set(seed: int, n: int = N_HELD_OUT, *, workers: int = 2, progress: bool = False, types=DEFAULT_TYPES):
    """The held-out "resting" Dataset (sampling seed 10 * seed + 8, not cached): n
    proposals of sampling's "resting" distribution over `types` (held_out), labelled by Drake."""
    return make_dataset("resting", n, 10 * seed + 8, types=types, workers=workers, progress=progress,
                        use_cache=False)


def outside_training(ds) -> np.ndarray:
    """(n,) bool: poses of a stacking Dataset beyond the training ranges (tilt of B's
    z axis from A's above TRAINING_TILT_DEG in roll or pitch, or depth above TRAINING_DEPTH)."""
    z_B = ds.R_AB[:, :, 2]  # (n, 3) B's z axis in A
    roll = np.degrees(np.abs(np.arctan2(z_B[:, 1], z_B[:, 2])))
    pitch = np.degrees(np.abs(np.arctan2(z_B[:, 0], z_B[:, 2])))
    return (np.maximum(roll, pitch) > TRAINING_TILT_DEG) | (ds.depth > TRAINING_DEPTH)


class GeometricPrior:
    """The improved predictor's geometric estimate alone (its network's correction
    zeroed): the simplest alternative every 'vs prior' gate compares with."""

    kind = "geometric_prior"

    def predict(self, p_AB, R_AB, *, size_A, size_B):
        """(point_A (n, 3) [m], normal_A (n, 3)) for poses (n, 3), (n, 3, 3) and sizes (n, 3)."""
        p_AB, R_AB = np.asarray(p_AB, float), np.asarray(R_AB, float)
        h_A = 0.5 * np.broadcast_to(np.asarray(size_A, float), p_AB.shape)
        h_B = 0.5 * np.broadcast_to(np.asarray(size_B, float), p_AB.shape)
        S, p_c, R_c = canonicalise(p_AB, R_AB)
        _, point_est, normal_est = features(p_c, R_c, h_A, h_B)
        normal = S * normal_est
        return S * point_est, normal / np.linalg.norm(normal, axis=1, keepdims=True)


def _figures_of(point, normal, ds) -> dict:
    e_point, e_normal = point_normal_errors(point, normal, ds)
    e_one_point = np.linalg.norm(point - ds.cop_one_point, axis=1)
    S = octant_signs(ds.p_AB)
    mae = paper_table(paper_outputs(point, normal, S), paper_outputs(ds.cop, ds.normal, S))["mean"]["MAE"]
    return {"point error median": float(np.median(e_point)), "point error p95": float(np.percentile(e_point, 95)),
            "point error p99": float(np.percentile(e_point, 99)),
            "normal error median": float(np.median(e_normal)), "normal error p95": float(np.percentile(e_normal, 95)),
            "MAE on the paper's 4 outputs": float(mae),
            # against the second reference: Drake's one-point rule (what its discrete solver applies)
            "point error vs one-point median": float(np.median(e_one_point)),
            "point error vs one-point p95": float(np.percentile(e_one_point, 95))}


def truth_gap_figures(data: dict) -> dict:
    """The truth's own discretisation error per pose set: |exact centre of pressure - Drake's
    one-point rule's| median, p95 and max [m] ("<set> truth gap median", ...), reported beside
    every point figure (what a gate against the one-point rule could not resolve)."""
    out = {}
    for dist, ds in data.items():
        gap = np.linalg.norm(ds.cop - ds.cop_one_point, axis=1)
        if len(gap):
            out.update({f"{dist} truth gap median": float(np.median(gap)),
                        f"{dist} truth gap p95": float(np.percentile(gap, 95)),
                        f"{dist} truth gap max": float(gap.max())})
    return out


def answer_figures(answers: dict, data: dict) -> dict:
    """Every gate's figure for answers {set: (point (n, 3), normal (n, 3))} and their
    prior's on the same poses (the prior is computed here)."""
    prior = GeometricPrior()
    out = {}
    for dist, ds in data.items():
        mine = _figures_of(*answers[dist], ds)
        base = _figures_of(*prior.predict(ds.p_AB, ds.R_AB, size_A=ds.size_A, size_B=ds.size_B), ds)
        for name, value in mine.items():
            out[f"{dist} {name}"] = value
            if "one-point" not in name:
                out[f"{dist} {name} vs prior"] = value / base[name] if base[name] > 0 else float("inf")
            out[f"prior: {dist} {name}"] = base[name]
    out.update(truth_gap_figures(data))
    return out


def gate_figures(predictor, data: dict) -> dict:
    """The measured figure of every gate in THRESHOLDS (and more) for `predictor` on `data`."""
    answers = {d: predictor.predict(ds.p_AB, ds.R_AB, size_A=ds.size_A, size_B=ds.size_B) for d, ds in data.items()}
    return answer_figures(answers, data)


def limit_unit(name: str) -> str:
    """Unit of a KNOWN_LIMITS figure: "x" for ratios to the prior, "deg" for normals, else "m"."""
    return next((unit for key, unit in LIMIT_UNITS.items() if key in name), "m")


def truth_uncertainty(name: str, figures: dict) -> float:
    """The reference's own uncertainty on gate `name`'s figure, in its unit: the exact integral's
    verified error (EXACT_LABEL_TOLERANCE_M for points; the normal is exact under either rule,
    EXACT_NORMAL_TOLERANCE_DEG), as a ratio to the prior's figure for a "vs prior" gate."""
    unit = limit_unit(name)
    base = name[:-len(" vs prior")] if name.endswith(" vs prior") else name
    own = EXACT_NORMAL_TOLERANCE_DEG if "normal" in base else EXACT_LABEL_TOLERANCE_M
    if "MAE" in base:
        own = EXACT_NORMAL_TOLERANCE_DEG * np.pi / 180.0  # [rad]: the paper's angles of point and force
    if unit == "x":
        prior = figures.get(f"prior: {base}", float("nan"))
        return float(own / prior) if prior > 0 else float("nan")
    return float(own)


def _beside(name: str, figures: dict) -> str:
    """The truth's own discretisation gap on the gate's poses, said beside a point figure."""
    dist = name.split(" ")[0]
    if "point" not in name or f"{dist} truth gap median" not in figures:
        return ""
    return (f"; the one-point rule (Drake's discrete solver) lies {figures[f'{dist} truth gap median'] * 1e3:.3g} mm "
            f"(median) / {figures[f'{dist} truth gap p95'] * 1e3:.3g} mm (p95) from this truth on these poses")


def verdicts(figures: dict, n: int, seed) -> list[dict]:
    """The gates (dicts as metrics.json holds them) judged from `figures`. A gate whose
    pose set `figures` does not cover (its first word, e.g. "resting") is left out, so a
    caller measuring fewer sets judges those it has. Every gate carries the truth's own
    uncertainty on its figure ("truth_uncertainty") and, for a point figure, the one-point
    rule's distance from the truth on the same poses in its description."""
    measured = {name.split(" ")[0] for name in figures}
    out = [{"name": name, "passed": bool(figures[name] <= limit), "value": figures[name], "threshold": limit,
            "unit": unit, "truth_uncertainty": truth_uncertainty(name, figures),
            "description": f"{name} on {n} held-out poses per set (seed {seed}) against the exact centre of pressure, "
                           f"must be <= {limit} {unit}{_beside(name, figures)}"}
           for name, (limit, unit) in THRESHOLDS.items() if name.split(" ")[0] in measured]
    for name, (target, figure, factors, why) in KNOWN_LIMITS.items():
        if name.split(" ")[0] not in measured:
            continue
        gate = pinned(name, figures[name], target, limit_unit(name), f"{name} (seed {seed}, {n} poses per set)",
                      KnownLimit(figure, tuple(factors), why))
        out.append({**gate.to_dict(), "passed": bool(gate.passed), "truth_uncertainty": truth_uncertainty(name, figures)})
    return out


def evaluate_gates(seed: int = 0, *, predictor_path=None, n: int = N_HELD_OUT) -> dict:
    """Gates of the predictor at `predictor_path` (default: shipped) on fresh held-out poses."""
    data = held_out(seed, n)
    figures = gate_figures(load_predictor(predictor_path), data)
    return {"gates": verdicts(figures, n, seed), "figures": figures, "n": n, "seed": seed,
            "n_outside": len(data["outside"])}
