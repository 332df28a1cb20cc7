"""`testbed study truth`: a truth ladder for motion (docs/truth.md).

Runs shipped scenes under a ladder of truths and says, per scene, how far the default truth
(Drake's discrete plant with polygon contact surfaces at the scene's time step) is from a
converged answer, and what each rung costs. One job per module:

  mesh_refine  Drake's compliant box mesh refined (red refinement) and written as .vtk
  scene        builds a rung's diagram build_scene cannot (a mesh, a continuous plant)
  rungs        the rungs: how each is built and run, measured alike
  quantities   the gated quantities from a run's records
  gci          the Grid Convergence Index (Celik et al. 2008) with its degenerate cases
  run          scenes x rungs, the GCIs, the reference and the classification
  report       truth.json and truth.md

This `__init__` registers the study (TruthStudy) and stays light for the CLI's parser: the
modules above are imported when it runs.
"""

from __future__ import annotations

import dataclasses
import math
import typing
from pathlib import Path

from testbed.errors import TestbedError
from testbed.studies import register
from testbed.studies.base import Study, floats


@dataclasses.dataclass
class TruthConfig:
    """scenes: shipped scene names or files (None: run.FULL_SCENES, or run.QUICK_SCENES with
    quick); rungs: some of rungs.RUNGS (None: all); accuracies: of the continuous rung (None:
    rungs.DEFAULT_ACCURACIES); duration [s]: replaces every scene's (None: each scene's own);
    quick: two scenes for 0.1 s; progress: a line per rung."""

    scenes: typing.Optional[typing.List[str]] = None
    rungs: typing.Optional[typing.List[str]] = None
    accuracies: typing.Optional[typing.List[float]] = None
    duration: typing.Optional[float] = None
    quick: bool = False
    progress: bool = True


def _code():
    """(run, report, rungs), imported on first use (they import pydrake)."""
    from testbed.studies.truth import report, run, rungs

    return run, report, rungs


@register
class TruthStudy(Study):
    name = "truth"
    help = ("how far each scene's default truth is from a converged one, and what each rung of the truth ladder costs "
            "(--duration [s] replaces every scene's)")
    order = 60
    Config = TruthConfig

    def add_arguments(self, group) -> None:
        group.add_argument("--scenes", help="comma-separated scene names or files (default: the overhang pair, two_stack, "
                                            "single_drop, crane_hard_landing, stack_slide_rest, crane_edge_landing; "
                                            "--quick overhang_hold,two_stack for 0.1 s)")
        group.add_argument("--rungs", help="comma-separated, some of polygon,triangle,half_step,refined_L1,refined_L2,"
                                           "continuous (default all)")
        group.add_argument("--accuracies", help="error-control accuracies of the continuous rung (default 1e-3,1e-4)")

    def configure(self, args) -> TruthConfig:
        accuracies = floats(args.accuracies, "--accuracies", ())
        if any(not a < 1 for a in accuracies) or len(set(accuracies)) != len(accuracies):
            raise TestbedError(f"--accuracies: expected distinct numbers below 1, got {list(accuracies)}")
        if args.duration is not None and not (math.isfinite(args.duration) and 0 < args.duration <= 3600):
            raise TestbedError(f"--duration: expected a number of seconds in (0, 3600], got {args.duration}")
        scenes = None
        if args.scenes is not None:
            scenes = [n.strip() for n in args.scenes.split(",") if n.strip()]
            if not scenes:
                raise TestbedError(f"--scenes: expected comma-separated scene names, got {args.scenes!r}")
        return TruthConfig(scenes=scenes, rungs=[x.strip() for x in args.rungs.split(",")] if args.rungs else None,
                           accuracies=list(accuracies) or None, duration=args.duration, quick=bool(args.quick),
                           progress=not args.quiet)

    def run(self, config: TruthConfig, out: Path, map_calls=None) -> dict:
        """Rungs checked (TestbedError), scenes loaded and built (ScenarioError) before anything
        runs or is written; the meshes cached under <out>/mesh_cache."""
        run, _, rungs = _code()
        unknown = [r for r in config.rungs or () if r not in rungs.RUNGS]
        if unknown:
            raise TestbedError(f"--rungs: unknown {unknown}; expected some of: {', '.join(rungs.RUNGS)}")
        names = list(config.scenes or (run.QUICK_SCENES if config.quick else run.FULL_SCENES))
        scenes = run.load_scenes(names, config.duration, config.quick)  # ScenarioError -> exit 2, nothing written

        def on_rung(scene, row):
            if config.progress:
                wall = f"{row['wall_s']:.2f} s" if row["wall_s"] is not None else row["error"][:100]
                print(f"  {scene} / {row['rung']}: {row['status']}, {wall}", flush=True)

        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        return run.run_loaded(scenes, rungs=tuple(config.rungs or rungs.RUNGS),
                              accuracies=tuple(config.accuracies or rungs.DEFAULT_ACCURACIES), quick=config.quick,
                              cache_dir=out / "mesh_cache", on_rung=on_rung)

    def report(self, study: dict, out: Path) -> list[Path]:
        """truth.json and truth.md."""
        _code()[1].write_report(study, out)
        return [Path(out) / "truth.json", Path(out) / "truth.md"]

    def summary(self, study: dict) -> list[str]:
        return _code()[1].summary_lines(study)
