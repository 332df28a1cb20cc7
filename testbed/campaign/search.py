"""The worst-case search of `testbed campaign --search`: the cross-entropy method (CEM) over a family's
`vary:` fields, maximising the candidate's error against the truth.

What it maximises (`objective`): a judged sample's `final_error_m` (testbed/campaign/sample.py), the
largest distance between where a free container ends in the candidate's run and where it ends in the
truth's: the one continuous quantity a campaign already computes per sample in metres, the one its
error distribution is read from and its worst samples are ranked by (the outcome class is categorical;
the final angle is recorded beside it). A candidate that ends nowhere (no final pose: nan or inf) scores +inf, as wrong as it gets; a
sample refused as a scene file or whose run failed scores -inf and never becomes an elite. The truth's
own spread (its 1 mm perturbed twin) is not subtracted: a worst case on a sensitive truth is reported with
`well_posed` false, as the campaign's worst samples are.

The method, one generation at a time: draw `population` parameter vectors from a distribution per field,
run them, keep the elite (the best ELITE_FRACTION of a generation's size, at least MIN_ELITE runs, taken
from every run so far, so that a small generation cannot lose the best case found), refit each field's
distribution to the elite (blended with the previous one by SMOOTHING, its spread never below
MIN_SD_FRACTION of the field's range), repeat until the budget of runs is spent. Per field:
  uniform [lo, hi]      a normal truncated to [lo, hi] (mean and sd of the elite; drawn by its inverse CDF)
  normal [mean, sd]     a normal truncated where the family truncates it, mean +- TRUNCATE_SD sd
  choice [a, b, ...]    categorical probabilities (the elite's frequencies; none below MIN_PROBABILITY, or
                        half the uniform's 1/k where k, the choices, is above 10)
The first generation is the family's own distribution: the scrambled Halton points a campaign with the same
seed samples first (family.halton_values), so the search starts where random sampling does and spends the
rest of its budget where the error is. Later generations draw from numpy's generator seeded by
(seed, generation): a search is a deterministic function of its seed and the runs' results, so a resumed
search proposes the same samples again and finds their records in the out dir.

Why CEM and not Bayesian optimisation (a Gaussian-process surrogate and an acquisition function): a
campaign's runs cost seconds each and the budget is a few dozen; CEM is a few lines of numpy (with
scipy's normal CDF, already a dependency), where a GP library (scikit-optimize, BoTorch) is a heavy
dependency for one option; it takes mixed continuous and
categorical fields natively (a GP needs an encoding and a kernel for the choices); and it proposes a whole
generation at once, which the campaign's executor (a local process pool or Ray: map_calls) runs in
parallel, where BO's acquisition is sequential, one point per fit (batch BO exists, at more dependencies and
more tuning). BO can find a maximum in fewer runs on a smooth objective; contact outcomes are not smooth
(a box seats or tips), which a GP's smoothness prior fits badly and a population method does not assume.
"""

from __future__ import annotations

import math

import numpy as np

from testbed.campaign.family import TRUNCATE_SD, Varied, halton_values

ELITE_FRACTION = 0.25  # [-] the elite's size, of a generation's
MIN_ELITE = 3  # the elite holds at least this many runs (a fit to one or two points says little of a spread)
SMOOTHING = 0.7  # [-] the elite's fit's weight against the previous distribution
MIN_SD_FRACTION = 0.02  # [-] a continuous field's sd never below this fraction of its range
MIN_PROBABILITY = 0.05  # [-] each of a choice field's values keeps at least this (at most 1/(2k)), then renormalised


def objective(record: dict) -> float:
    """What the search maximises for one sample's record (module docstring)."""
    if record.get("status") != "ok":
        return -math.inf
    error = float(record["final_error_m"])
    return error if math.isfinite(error) else math.inf


def bounds(v: Varied) -> tuple[float, float]:
    """A continuous field's support: [lo, hi] for uniform, mean +- TRUNCATE_SD sd for normal."""
    if v.kind == "uniform":
        return float(v.args[0]), float(v.args[1])
    mean, sd = v.args
    return float(mean - TRUNCATE_SD * sd), float(mean + TRUNCATE_SD * sd)


def truncated_normal(rng, mean: float, sd: float, lo: float, hi: float, n: int) -> np.ndarray:
    """n draws of a normal(mean, sd) truncated to [lo, hi], by its inverse CDF (mean within [lo, hi])."""
    from scipy.special import ndtr, ndtri

    a, b = ndtr((lo - mean) / sd), ndtr((hi - mean) / sd)
    x = mean + sd * ndtri(a + rng.random(n) * (b - a))
    return np.clip(x, lo, hi)  # the inverse CDF's rounding at the ends


class CrossEntropySearch:
    """CEM over `varied` (the family's Varied fields). propose(n) -> n vectors {path: value}; tell(vectors,
    scores) records their scores (higher is worse for the candidate) and refits. Seeded: the same seed and
    the same scores give the same proposals."""

    def __init__(self, varied, population: int, seed: int, elite_fraction: float = ELITE_FRACTION):
        if population < 1 or not varied or seed < 0:
            raise ValueError("a search needs a population of at least 1, at least one field and a seed >= 0")
        self.varied, self.population, self.seed = tuple(varied), population, seed
        self.elite_size = max(MIN_ELITE, math.ceil(elite_fraction * population))
        self.generation = 0  # generations proposed so far
        self.tried: list[tuple[dict, float]] = []
        self.mean, self.sd, self.probs = {}, {}, {}
        for v in self.varied:  # the family's own distribution, as the first refit's previous one
            if v.kind == "choice":
                self.probs[v.path] = np.full(len(v.args), 1.0 / len(v.args))
            elif v.kind == "uniform":
                lo, hi = bounds(v)
                self.mean[v.path], self.sd[v.path] = 0.5 * (lo + hi), (hi - lo) / math.sqrt(12.0)
            else:
                self.mean[v.path], self.sd[v.path] = float(v.args[0]), float(v.args[1])

    def propose(self, n: int | None = None) -> list[dict]:
        """The next generation: n (default: the population) vectors {path: value}."""
        n = self.population if n is None else n
        g, self.generation = self.generation, self.generation + 1
        if g == 0:
            return halton_values(self.varied, n, self.seed)
        rng = np.random.default_rng((self.seed, g))
        columns = {}
        for v in self.varied:
            if v.kind == "choice":
                picks = rng.choice(len(v.args), size=n, p=self.probs[v.path])
                columns[v.path] = [v.args[int(k)] for k in picks]
            else:
                lo, hi = bounds(v)
                columns[v.path] = [float(x) for x in truncated_normal(rng, self.mean[v.path], self.sd[v.path], lo, hi, n)]
        return [{path: column[i] for path, column in columns.items()} for i in range(n)]

    def elite(self) -> list[tuple[dict, float]]:
        """The best elite_size runs so far (refused and failed ones, scored -inf, never)."""
        scored = [t for t in self.tried if t[1] > -math.inf]
        order = sorted(range(len(scored)), key=lambda i: (-scored[i][1], i))  # ties: the earlier run
        return [scored[i] for i in order[:self.elite_size]]

    def tell(self, vectors: list[dict], scores) -> None:
        """Records a generation's scores and refits each field's distribution to the elite."""
        self.tried += [(dict(v), float(s)) for v, s in zip(vectors, scores, strict=True)]
        elite = [values for values, _ in self.elite()]
        if not elite:  # nothing judged yet: the distribution stays
            return
        a = SMOOTHING
        for v in self.varied:
            if v.kind == "choice":
                counts = np.zeros(len(v.args))
                for values in elite:
                    counts[v.args.index(values[v.path])] += 1
                floor = min(MIN_PROBABILITY, 0.5 / len(v.args))  # half the mass free to move, however many values
                p = np.maximum(a * counts / counts.sum() + (1 - a) * self.probs[v.path], floor)
                self.probs[v.path] = p / p.sum()
            else:
                lo, hi = bounds(v)
                x = np.array([values[v.path] for values in elite], dtype=float)
                self.mean[v.path] = float(np.clip(a * x.mean() + (1 - a) * self.mean[v.path], lo, hi))
                self.sd[v.path] = float(np.clip(a * x.std() + (1 - a) * self.sd[v.path], MIN_SD_FRACTION * (hi - lo), hi - lo))

    def state(self) -> dict:
        """Each field's current distribution: {path: {"mean", "sd"} or {"probabilities": {value: p}}} (a value
        listed twice in a choice: its probabilities summed)."""
        out: dict = {}
        for v in self.varied:
            if v.kind != "choice":
                out[v.path] = {"mean": self.mean[v.path], "sd": self.sd[v.path]}
                continue
            probabilities: dict = {}
            for c, p in zip(v.args, self.probs[v.path]):
                probabilities[str(c)] = probabilities.get(str(c), 0.0) + float(p)
            out[v.path] = {"probabilities": probabilities}
        return out


def default_population(budget: int) -> int:
    """A generation's size for a budget: about its square root (as many generations as runs in each), at least
    2 and at most the budget."""
    return min(budget, max(2, round(math.sqrt(budget))))


def maximise(evaluate, varied, budget: int, seed: int, population: int | None = None, score=objective,
             on_generation=None):
    """Spends `budget` runs, a generation at a time: evaluate(vectors, first index, generation) -> their
    records, each scored by score(record); on_generation(step) after each generation. Returns (the search,
    every record in order, the history: per generation its runs' first and last index, its best score, the
    best so far and the elite's mean score; None where nothing was judged)."""
    search = CrossEntropySearch(varied, population or default_population(budget), seed)
    records: list = []
    history: list[dict] = []
    while len(records) < budget:
        first, generation = len(records), search.generation
        vectors = search.propose(min(search.population, budget - first))
        batch = list(evaluate(vectors, first, generation))
        scores = [score(r) for r in batch]
        search.tell(vectors, scores)
        records += batch
        elite = [s for _, s in search.elite()]
        judged = [s for _, s in search.tried if s > -math.inf]
        step = {"generation": generation, "runs": [first, first + len(vectors) - 1],
                "best": max((s for s in scores if s > -math.inf), default=None),
                "best_so_far": max(judged, default=None),
                "elite_mean": float(np.mean(elite)) if elite else None, "distribution": search.state()}
        history.append(step)
        if on_generation is not None:
            on_generation(step)
    return search, records, history


def worst(records: list[dict], count: int) -> list[int]:
    """The indices of the `count` records scoring highest (judged ones only), worst first."""
    scored = [r for r in records if objective(r) > -math.inf]
    return [r["index"] for r in sorted(scored, key=lambda r: (-objective(r), r["index"]))[:count]]
