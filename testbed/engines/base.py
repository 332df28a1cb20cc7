"""The Engine protocol: a simulator that runs the testbed's scenes.

An engine is one package of testbed/engines/ whose `__init__` registers an Engine subclass
with `testbed.engines.register`. Every engine answers the same three questions:

  name                     its registry name (`testbed compare --engine NAME`, the
                           simulation study's `engines`, the engine case kind)
  check(scenario)          None, or UnsupportedSceneError (a ScenarioError: the scene,
                           the field and why) before anything runs
  run(scenario, ...)       an EngineRun: the Trajectory of the free containers every
                           `record_every` steps, and (contacts=True) its contact rows

Contact rows are one row per touching body pair per step, in the shape of
testbed/effects/contact_log.py's `contacts` table: step, time [s], a, b (body indices,
a < b, ground = 0), p_W_cop (n, 3) [m], n_W (n, 3) unit a -> b, f_W (n, 3) [N] on b,
phi (n,) [m] (negative = penetration). `reference` marks Drake, the ground truth every
other engine is judged against; `gated` marks the run that the closed-loop gates judge
(the learned loop); `param_sets` names an engine's contact-parameter sets, first the default;
`learned` marks an engine whose container contact a predictor decides (mujoco_learned);
`drake_hosted` marks Drake's own engines (its contact rows are the truth's own kind).

run's `params` is a contact-parameter set only (one of `param_sets`; Drake's: a contact
model), `predictor` the learned contact model (a learned_contact.sources spec) of a learned or
gated engine only: an engine refuses the one it has no use for (ValueError) rather than read
one as the other.
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

from testbed.errors import ScenarioError


class UnsupportedSceneError(ScenarioError):
    """A scene an engine cannot simulate: "scene '<name>': <field> <problem>" (one line)."""

    def __init__(self, scene: str, field: str, problem: str):
        super().__init__(f"scene '{scene}'", "", f"{field} {problem}" if field else problem)
        self.field = field


@dataclasses.dataclass
class EngineRun:
    """One engine's run of one scene (see the module doc for the contact rows).

    trajectory: testbed.simulation.Trajectory (its `error` says how a failed run ended);
    contacts: the contact rows, or None when not asked for; summary: engine-specific
    figures (version, wall_per_sim_s [s per simulated s], max_penetration_m [m], ...);
    files: extra output files, name -> text (e.g. the translated model)."""

    trajectory: Any
    contacts: dict | None = None
    summary: dict = dataclasses.field(default_factory=dict)
    files: dict = dataclasses.field(default_factory=dict)


class Engine:
    """Base class of engines (see the module doc). Subclasses set `name`, `label` and
    override `check` and `run`; `unavailable` and `version` where a package is optional."""

    name: ClassVar[str] = ""
    label: ClassVar[str] = ""  # as printed: "MuJoCo"
    order: ClassVar[int] = 100  # registry order; lower first
    reference: ClassVar[bool] = False  # the ground truth the others are judged against (Drake)
    gated: ClassVar[bool] = False  # judged by the closed-loop gates (the learned loop)
    param_sets: ClassVar[tuple[str, ...]] = ()  # contact-parameter sets, the default first
    # a learned predictor decides its container contact (mujoco_learned): compare judges it at the
    # learned law's modulus by the closed-loop gates, and its params name the predictor
    learned: ClassVar[bool] = False
    drake_hosted: ClassVar[bool] = False  # Drake's own plant steps it (drake, learned)
    # what validate's report says of this engine beside its rows (the report names no engine itself)
    report_note: ClassVar[str] = ""
    # the query study's method that times this engine's own contact query ("" if none): the report's
    # candidates table takes its contact-point error and cost per query from it
    query_method: ClassVar[str] = ""

    def unavailable(self) -> str | None:
        """Why this engine cannot run here (a missing package and its install command), or None."""
        return None

    def version(self) -> str:
        return ""

    def check(self, scenario) -> None:
        """Raises UnsupportedSceneError when this engine cannot run `scenario`."""

    def run(self, scenario, *, duration: float | None = None, record_every: int = 1, params: str | None = None,
            predictor: str | None = None, contacts: bool = False, source: object = "<scenario>") -> EngineRun:
        """Simulates `scenario` for `duration` [s] (None: the scene's) from its initial state,
        recording every `record_every` plant steps; `params`: one of `param_sets` (None: the
        first); `predictor`: a learned engine's predictor spec (None: the scene's
        learned_dynamics predictor if it declares one, else the shipped default); `contacts`:
        also return the contact rows. A run that fails ends early with trajectory.error set
        (testbed/simulation.py's failure convention)."""
        raise NotImplementedError

    def refuse_unused(self, params: str | None, predictor: str | None) -> None:
        """ValueError when `params` is not one of param_sets, or `predictor` is given to an
        engine that is neither learned nor gated (a caller mixing the two up)."""
        if params is not None and params not in self.param_sets:
            raise ValueError(f"engine {self.name}: params {params!r} is not one of its contact-parameter sets "
                             f"({', '.join(self.param_sets) or 'none'}); a predictor goes in predictor=")
        if predictor is not None and not (self.learned or self.gated):
            raise ValueError(f"engine {self.name}: no predictor decides its contact (predictor={predictor!r})")
