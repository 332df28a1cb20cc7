"""The `scale` study: what a yard of N containers costs per step with each contact model and
engine, timed past the settling transient, and how that cost grows with N.

For each size N (a yard block of rows x bays x tiers, testbed/bodies/yards.py), each model
(every registered engine gives its models: settings.py) and each yard kind (settled: nothing
happens; crane: one load landing on a stack inside the block), one cell settles the yard
untimed and then times a window from the settled state (cells.py): the MuJoCo-hosted learned
loop's window continues its 0.8 s settling run, so that its sleeping islands are asleep when
the window starts (window.py; each row says what fraction of the yard is), the others' is a
fresh run from the state a shorter settling run ended in. The report gives the cost
per step [ms] and x real time per size, and the growth exponent of the cost per step in N per
model and yard kind, fitted once per pass of the whole grid (fit.py), against the targets of
targets.py. One job per module:

  settings  the models (from the engine registry) and ScaleConfig
  yard      the yard blocks for N: layout, the crane's load and stack, the settled state
  window    the timed window as the continuation of the settling run (sleeping islands asleep)
  cells     one run per (pass, N, model, yard): settle, then the timed window
  fit       the growth exponent and its spread
  grid      the whole grid as one record (run_study)
  targets   the study's targets read from a record
  report    scale.json, scale.md, scale.html, scale_cost.png; the printed summary

`from testbed.studies.scale import ScaleConfig, run_cell, tasks, ...` keeps working: the names
of these modules are read from them on first use (this `__init__` stays light for the CLI).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from testbed.studies import register
from testbed.studies.base import Study, choices
from testbed.studies.scale.settings import QUICK, ScaleConfig, ScaleConfigError, models

_MODULES = ("settings", "yard", "window", "cells", "fit", "grid", "targets", "report")


def _code():
    """(grid, report), imported on first use (they import pydrake and matplotlib)."""
    from testbed.studies.scale import grid, report

    return grid, report


def _int_list(text: str, option: str) -> tuple[int, ...]:
    try:
        return tuple(int(x) for x in text.split(","))
    except ValueError:
        raise ScaleConfigError(f"{option}: expected comma-separated whole numbers, got {text!r}") from None


def _caps(text: str) -> tuple[tuple[str, int], ...]:
    """MODEL=N,... -> ((model, N), ...); 'none' -> ()."""
    if text.strip().lower() == "none":
        return ()
    out = []
    for item in text.split(","):
        model, _, n = item.partition("=")
        try:
            out.append((model.strip(), int(n)))
        except ValueError:
            raise ScaleConfigError(f"--caps: expected MODEL=N,... (or none), got {text!r}") from None
    return tuple(out)


@dataclasses.dataclass
class ScaleRun:
    """The scale study's run settings: its grid (ScaleConfig) and where its cells run:
    executor 'sequential' (this process), 'local' (workers processes) or 'ray' (address)."""

    grid: ScaleConfig = dataclasses.field(default_factory=ScaleConfig)
    executor: str = "sequential"
    workers: int = 2
    address: str | None = None
    progress: bool = True


@register
class ScaleStudy(Study):
    name = "scale"
    help = "what a yard of N containers costs per step with each model and engine, past the settling, and its growth in N"
    order = 50
    Config = ScaleRun

    def add_arguments(self, group) -> None:
        d = ScaleConfig()
        group.add_argument("--sizes", help=f"containers per yard, multiples of --tiers (default {','.join(map(str, d.sizes))}; "
                                           f"--quick {','.join(map(str, QUICK.sizes))})")
        group.add_argument("--tiers", type=int, help=f"tiers of every yard block (default {d.tiers})")
        group.add_argument("--settle", type=float, help=f"[s] simulated from rest, untimed, before every timed window (the "
                                                        "MuJoCo-hosted learned loop's window continues that run) "
                                                        f"(default {d.settle_s:g}; --quick {QUICK.settle_s:g})")
        group.add_argument("--fresh-settle", type=float, help=f"[s] the settle of the models whose window is a fresh run "
                                                              f"from the settled state, at most --settle (default {d.fresh_settle_s:g})")
        group.add_argument("--big-duration", type=float, help=f"[s] timed window above --big-above containers (default {d.big_duration:g})")
        group.add_argument("--big-above", type=int, help=f"containers above which windows are --big-duration long (default {d.big_above})")
        group.add_argument("--models", help="comma-separated, some of the models every registered engine gives "
                                            "(hydroelastic,point,learned,mujoco,mujoco_learned,...; default all)")
        group.add_argument("--yards", help="comma-separated, some of settled,crane (default both)")
        group.add_argument("--caps", help="MODEL=N,...: the largest N each model runs, or none (default "
                                          + ",".join(f"{m}={n}" for m, n in d.caps) + "; --quick none)")
        group.add_argument("--passes", type=int, help=f"times the whole grid is measured, one growth fit each (default {d.passes}; --quick 1)")
        group.add_argument("--clock", choices=["wall", "cpu"], help="the cost per step the fits and targets read: the "
                                                                     "window's wall time (default) or this process's CPU "
                                                                     "time less a second build's (noisy at big N)")
        group.add_argument("--predictor", help="predictor of the learned loops (default: each engine's own, 'improved')")
        group.add_argument("--executor", choices=["sequential", "local", "ray"], default="sequential",
                           help="where the cells run: sequential (default, in this process: undisturbed timings), local "
                                "(--workers processes) or ray (validate's executors; cells side by side share the machine)")
        group.add_argument("--address", help="Ray cluster address for --executor ray (default: a local Ray started here)")

    def configure(self, args) -> ScaleRun:
        """A ScaleConfig from the options (--quick: the small grid); a bad value is a
        ScaleConfigError (exit 2) before anything runs."""
        given = {}
        if args.sizes:
            given["sizes"] = _int_list(args.sizes, "--sizes")
        if args.models:
            given["models"] = choices(args.models, "--models", tuple(models()), ())
        if args.yards:
            given["yards"] = tuple(y.strip() for y in args.yards.split(","))
        if args.caps:
            given["caps"] = _caps(args.caps)
        for option, field in (("tiers", "tiers"), ("duration", "duration"), ("big_duration", "big_duration"),
                              ("big_above", "big_above"), ("predictor", "predictor"), ("settle", "settle_s"), ("fresh_settle", "fresh_settle_s"),
                              ("passes", "passes"), ("clock", "clock")):
            if getattr(args, option) is not None:
                given[field] = getattr(args, option)
        config = dataclasses.replace(QUICK if args.quick else ScaleConfig(), **given)
        config.validate()
        return ScaleRun(config, args.executor, args.workers, args.address, not args.quiet)

    def run(self, config: ScaleRun, out: Path, map_calls=None) -> dict:
        """The grid's cells here one after the other (executor 'sequential'), or through
        `map_calls` (validate's executors, handed in by the command: this layer does not import them)."""
        grid, _ = _code()
        if config.executor == "sequential":
            return grid.run_study(config.grid, progress=config.progress)
        if map_calls is None:
            raise ScaleConfigError(f"--executor {config.executor}: no executor was handed to the study")

        def cells(fn, items, done):
            map_calls(fn, items, done, executor=config.executor, workers=config.workers, address=config.address)

        return grid.run_study(config.grid, map_cells=cells, executor=config.executor)

    def report(self, study: dict, out: Path) -> list[Path]:
        return _code()[1].write_report(study, out)

    def summary(self, study: dict) -> list[str]:
        return _code()[1].summary_lines(study)


def __getattr__(name):
    if name.startswith("__") or name in _MODULES:  # a submodule itself: imported, not forwarded
        raise AttributeError(name)
    import importlib

    for module in _MODULES:
        found = importlib.import_module(f"{__name__}.{module}")
        if hasattr(found, name):
            return getattr(found, name)
    raise AttributeError(name)
