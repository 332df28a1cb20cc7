"""Registry of engines: the simulators that run the testbed's scenes (testbed/engines/base.py).

Adding an engine = one package here whose `__init__` registers an Engine subclass with
`register`. Registered: `drake` (the ground truth: its contact models) and `learned` (the
learned closed loop, a Drake variant) in drake/, `mujoco` in mujoco/, `bullet` (Bullet, through
pybullet) in bullet/, `mujoco_learned` (MuJoCo stepping the bodies, a predictor deciding
container contact) in mujoco_learned/. Every package is imported on the registry's first use;
none imports its simulator's package until it runs.

Beside the packages: candidate.py (Candidate: an engine, its contact parameters, its predictor),
comparison.py (the Drake variants an engine is judged against) and three_way.py (the learned
law's modulus of `--engine all`). The comparison itself, every
candidate against one reference run, is testbed/compare/run_candidates.py.
"""

from testbed.engines.base import Engine, EngineRun, UnsupportedSceneError
from testbed.errors import UnknownChoiceError
from testbed.plugins import PackageRegistry

_REGISTRY = PackageRegistry(__name__, __path__, "engine", instantiate=True, skip=("base", "candidate", "comparison", "three_way"))
register = _REGISTRY.register


def engines() -> dict[str, Engine]:
    """All engines by name (instances), in registry order."""
    return _REGISTRY.entries()


def engine(name: str) -> Engine:
    """The engine `name`, or UnknownChoiceError naming the registered ones."""
    found = engines()
    if name not in found:
        raise UnknownChoiceError("engine", name, found)
    return found[name]


def candidates() -> dict[str, Engine]:
    """The engines judged against the reference (every one but Drake's truth), in order."""
    return {name: e for name, e in engines().items() if not e.reference}


def alternatives() -> list[Engine]:
    """The whole-simulator alternatives: every candidate but the gated learned loop (MuJoCo)."""
    return [e for e in candidates().values() if not e.gated]


__all__ = ["Engine", "EngineRun", "UnsupportedSceneError", "alternatives", "candidates", "engine", "engines", "register"]
