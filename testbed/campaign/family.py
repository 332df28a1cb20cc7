"""A scene family: a scene file plus a `vary:` mapping from field paths (as `--set` writes them:
`containers[3].X_WC.translation[0]`, `containers[3].X_WC.rotation.deg[1]`, `containers[3].mass`,
`effects.wind.speed`) to distributions:

    vary:
      containers[3].X_WC.rotation.deg[0]: {uniform: [2.0, 10.0]}
      containers[3].mass: {normal: [20000.0, 3000.0]}      # truncated to mean +- 3 sd
      containers[3].type: {choice: [1CC, 1AA]}

and optionally `campaign: {duration: 2.0, samples: 32}` (the defaults of `testbed campaign`). The rest of
the file is a scene, loaded and checked as one. Samples are the points of a scrambled Halton sequence
(scipy.stats.qmc, seeded: low-discrepancy, so a few dozen cover the box evenly), mapped through each
distribution's inverse CDF; each becomes a list of --set overrides, and each is checked as a scene file
is (load_scenario): a refused sample keeps its field and drawn value and is never simulated.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import yaml

from testbed.errors import ScenarioError, one_of
from testbed.safe_files import check_regular_file
from testbed.scenario import load_scenario
from testbed.scene_yaml import SceneDumper, parse_override, parse_yaml

DISTRIBUTIONS = ("uniform", "normal", "choice")
TRUNCATE_SD = 3.0  # a normal distribution is truncated to mean +- 3 sd
MAX_FAMILY_BYTES = 256 * 1024
MAX_VARIED = 16  # fields a family may vary


@dataclasses.dataclass(frozen=True)
class Varied:
    path: str  # a --set field path
    kind: str  # uniform | normal | choice
    args: tuple

    def value(self, u: float):
        """The field's value at u in [0, 1) (the distribution's inverse CDF)."""
        if self.kind == "uniform":
            lo, hi = self.args
            return float(lo + u * (hi - lo))
        if self.kind == "normal":
            from scipy.stats import norm

            mean, sd = self.args
            lo, hi = norm.cdf(-TRUNCATE_SD), norm.cdf(TRUNCATE_SD)
            return float(mean + sd * norm.ppf(lo + u * (hi - lo)))
        return self.args[min(int(u * len(self.args)), len(self.args) - 1)]


@dataclasses.dataclass(frozen=True)
class Family:
    name: str
    source: str  # the family file
    scene_text: str  # the scene (the file without vary: and campaign:)
    varied: tuple  # of Varied
    duration: float  # [s] each sample's simulated time
    samples: int  # default count

    def sample(self, n: int, seed: int) -> list[dict]:
        """n samples: {"index", "values": {path: value}, "overrides": [...]}, the first n points of a
        scrambled Halton sequence in as many dimensions as varied fields (seeded)."""
        return [as_sample(i, values) for i, values in enumerate(halton_values(self.varied, n, seed))]


def halton_values(varied, n: int, seed: int) -> list[dict]:
    """The first n points of a scrambled Halton sequence (seeded) through each field's inverse CDF:
    [{path: value}, ...] (a campaign's samples; a worst-case search's first generation)."""
    from scipy.stats import qmc

    u = qmc.Halton(d=len(varied), scramble=True, seed=seed).random(n) if n else np.zeros((0, len(varied)))
    return [{v.path: v.value(float(x)) for v, x in zip(varied, row)} for row in u]


def as_sample(index: int, values: dict, **extra) -> dict:
    """A sample: {"index", "values": {path: value}, "overrides": the --set overrides that draw them, **extra}."""
    overrides = [f"{path}={yaml.dump(value, default_flow_style=True).strip().removesuffix('...').strip()}"
                 for path, value in values.items()]
    return {"index": index, "values": values, "overrides": overrides, **extra}


def _fail(source, field: str, problem: str):
    return ScenarioError(source, field, problem)


def _varied(source, path, spec) -> Varied:
    field = f"vary.{path}"
    try:
        parse_override(f"{path}=0")
    except ValueError as e:
        raise _fail(source, field, f"not a field path: {e}") from None
    if not isinstance(spec, dict) or len(spec) != 1:
        raise _fail(source, field, f"expected one distribution, {{uniform: [lo, hi]}}, {{normal: [mean, sd]}} or "
                                   f"{{choice: [a, b, ...]}}, got {spec!r}")
    (kind, args), = spec.items()
    if kind not in DISTRIBUTIONS:
        raise _fail(source, field, f"unknown distribution {kind!r}; {one_of(kind, DISTRIBUTIONS)}")
    if kind == "choice":
        if not isinstance(args, list) or not args or len(args) > 64:
            raise _fail(source, f"{field}.choice", f"expected a list of 1 to 64 values, got {args!r}")
        return Varied(path, kind, tuple(args))
    if not (isinstance(args, list) and len(args) == 2 and all(isinstance(a, (int, float)) and not isinstance(a, bool)
                                                               and math.isfinite(a) for a in args)):
        raise _fail(source, f"{field}.{kind}", f"expected two finite numbers, got {args!r}")
    a, b = (float(x) for x in args)
    if kind == "uniform" and not a < b:
        raise _fail(source, f"{field}.uniform", f"expected lo < hi, got [{a:g}, {b:g}]")
    if kind == "normal" and not b > 0:
        raise _fail(source, f"{field}.normal", f"expected a standard deviation > 0, got {b:g}")
    return Varied(path, kind, (a, b))


def load_family(path) -> Family:
    """The family at `path` (ScenarioError naming the file and field otherwise); its scene is checked."""
    path = Path(path)
    check_regular_file(path, MAX_FAMILY_BYTES, "scene family file (.yaml)", ScenarioError)
    data = parse_yaml(path.read_text(encoding="utf-8"), str(path))
    vary = data.pop("vary", None)
    settings = data.pop("campaign", None) or {}
    if not isinstance(vary, dict) or not vary:
        raise _fail(path, "vary", "expected a mapping of field paths to distributions (a family varies at least one field)")
    if len(vary) > MAX_VARIED:
        raise _fail(path, "vary", f"{len(vary)} fields; expected at most {MAX_VARIED}")
    if not isinstance(settings, dict) or set(settings) - {"duration", "samples"}:
        raise _fail(path, "campaign", f"expected a mapping of duration [s] and samples, got {settings!r}")
    varied = tuple(_varied(path, str(k), v) for k, v in vary.items())
    text = yaml.dump(data, Dumper=SceneDumper, sort_keys=False)
    scenario = load_scenario(text=text)  # the scene itself, as a scene file is checked
    duration = settings.get("duration", scenario.duration)
    samples = settings.get("samples", 32)
    if not (isinstance(duration, (int, float)) and duration > 0) or not (isinstance(samples, int) and samples > 0):
        raise _fail(path, "campaign", f"expected duration > 0 [s] and samples >= 1, got {settings!r}")
    return Family(name=scenario.name, source=str(path), scene_text=text, varied=varied, duration=float(duration),
                  samples=samples)


def checked_sample(family: Family, sample: dict):
    """(the sample's Scenario, None), or (None, the refusal: one line naming the field and the drawn value)."""
    try:
        return load_scenario(text=family.scene_text, overrides=sample["overrides"]), None
    except ScenarioError as e:
        field = e.field or "?"
        drawn = {p: v for p, v in sample["values"].items() if field.startswith(p) or p.startswith(field)} or sample["values"]
        return None, f"{field}: {e.problem} (drawn: {drawn})"
