"""Query-level study: what each contact method costs per query and how accurate it is.

    from testbed.studies.query import run_query_study
    metrics = run_query_study("reports/query", quick=True)

On the same poses of a container pair (A, B), every method is asked for one contact
point and one normal, timed side by side in this process, and compared with the
reference: Drake's static hydroelastic answer (compliant-compliant, E as shipped: 1e9 Pa), its
centre of pressure (CoP) and pressure-weighted normal (learned_contact/data/labels.py).

  poses.py      the pose sets (stacking, general, near_parallel) and their labels
  methods/      the ContactMethod interface (base.py) and one module per method family:
                drake.py (drake_point, drake_hydro_cc = the reference, drake_hydro_cr),
                polygon_soup.py (soup_N<N>, soup_segments_N8: the paper's RAPID
                baseline on python-fcl), mujoco.py (mujoco), learned.py
                (paper_mlp_single/_batched, improved_single/_batched). A method whose
                package or weights are missing is listed with available = false and
                the reason; the optional packages themselves raise
                OptionalDependencyError. A new method family is one new module there.
  measure.py    timing (fastest of `repeats` per pose, one BLAS thread)
  aggregate.py  statistics, Pareto fronts, the paper's Tables 3 and 4 on today's tools
  render.py     the chart and the report sections (testbed.document)
  paper.py      the paper's own figures, quoted
  study.py      run_query_study: all of the above, written to out_dir

query.json keys: schema; config (n_poses, seed, quick, repeats, soup_N, ...);
environment (versions, pins, blas_threads); reference; pose_sets {name: {n,
n_dropped}}; methods {name: {label, family, available, reason, [N,
triangles_per_box], all and by_set {set: {time_us, [kernel_time_us],
point_error_m, normal_error_deg, [count]}}, [throughput_us_per_pair]}}, each
statistic {n, n_missing, mean, median, p99, max}; polygon_soup {N: the paper's
Tables 3 and 4 on today's tools}; near_parallel_by_tilt; pareto {point_front,
normal_front}; paper (its Tables 3 and 4 and MLP time, quoted); wall_time_s; files;
markdown (the text of query.md). Timing-dependent (differ between runs): every
*time_us*, *_ms*, throughput_us_per_pair, wall_time_s, pareto, markdown.
"""

import dataclasses
from pathlib import Path

from testbed.studies import register
from testbed.studies.base import Study
from testbed.studies.query.aggregate import pareto_front
from testbed.studies.query.methods.base import ContactMethod
from testbed.studies.query.methods.learned import paper_predict
from testbed.studies.query.poses import POSE_SETS, PoseSet, make_pose_sets
from testbed.studies.query.study import SCHEMA, SOUP_N_FULL, SOUP_N_QUICK, run_query_study


@dataclasses.dataclass
class QueryConfig:
    """quick: fewer poses, repeats and soup resolutions (under a minute); progress: progress bars."""

    quick: bool = False
    progress: bool = True


@register
class QueryStudy(Study):
    name = "query"
    help = "time per contact query against accuracy for every contact method (the paper's Tables 3 and 4)"
    order = 20
    Config = QueryConfig

    def configure(self, args) -> QueryConfig:
        return QueryConfig(quick=bool(args.quick), progress=not args.quiet)

    def run(self, config: QueryConfig, out: Path, map_calls=None) -> dict:
        """run_query_study: measures and writes query.json, query.md and the chart into `out`."""
        return run_query_study(out, quick=config.quick, progress=config.progress)

    def report(self, result: dict, out: Path) -> list[Path]:
        """Nothing more: run_query_study wrote them (result['files'] names them)."""
        return [Path(out) / name for name in result["files"].values()]

    def summary(self, result: dict) -> list[str]:
        return result["markdown"].splitlines()


__all__ = ["POSE_SETS", "QueryConfig", "QueryStudy", "SCHEMA", "SOUP_N_FULL", "SOUP_N_QUICK", "ContactMethod", "PoseSet", "make_pose_sets",
           "paper_predict", "pareto_front", "run_query_study"]
