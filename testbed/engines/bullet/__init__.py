"""Bullet (pybullet) behind the Engine protocol (testbed/engines/base.py): the rigid-body
engine a game or crane simulator would use (PhysX, Unity, Bullet alike: boxes, a contact
manifold of points, an impulse solver, sleeping bodies), judged against Drake's truth.

  model.py   Scenario -> a Bullet world in DIRECT mode, with Bullet's default contact or
             a per-body stiffness and damping matched to Drake's hydroelastic contact
  loads.py   the applied-force effects (wind, deck_motion with its twistlocks, the crane):
             each effect's own law, applied before every step
  run.py     simulate_bullet: steps it, records the Drake-shaped `steps` and per-pair
             `contacts` tables and the wall time of the steps; trajectory_of

The registration stays light (the CLI's parser lists the engines): the modules above load
when a scene is checked or run, and `pybullet` only when one is built; a missing one (no
wheel for every Python) is a PybulletMissingError naming `pip install pybullet==3.2.7`.
README.md beside this file says what is matched and what cannot be.
"""

from __future__ import annotations

from testbed.engines import register
from testbed.engines.base import Engine, EngineRun
from testbed.errors import OptionalDependencyError

PARAM_SETS = ("matched", "default")  # Bullet's contact-parameter sets, the default first (model.py)


@register
class BulletEngine(Engine):
    """Bullet; params: 'matched' (contact stiffness and damping from Drake's hydroelastic
    contact, the default) or 'default' (Bullet's rigid contact)."""

    name = "bullet"
    label = "Bullet"
    order = 25
    param_sets = PARAM_SETS
    report_note = ("Bullet: a game engine's rigid bodies (pybullet, maximal coordinates, sleeping on with Bullet's "
                   "thresholds), with per-body contact stiffness and damping 'matched' to Drake's hydroelastic "
                   "foundation and with Bullet's 'default' rigid contact; its box contact is a manifold of at most "
                   "4 points (no pressure field), friction the product of per-body factors; its points per body "
                   "pair are reduced to the force-weighted centroid.")

    def unavailable(self) -> str | None:
        from testbed.engines.bullet.model import pybullet_module

        try:
            pybullet_module()
        except (ImportError, OptionalDependencyError) as e:
            return str(e).strip().splitlines()[0]
        return None

    def version(self) -> str:
        from testbed.engines.bullet.model import pybullet_version

        return pybullet_version()

    def check(self, scenario) -> None:
        from testbed.engines.bullet.model import check_supported

        check_supported(scenario)

    def run(self, scenario, *, duration=None, record_every=1, params=None, predictor=None, contacts=False,
            source="<scenario>"):
        """See Engine.run; no predictor (Bullet's contact is its own: a given one is refused)."""
        from testbed.engines.bullet.run import simulate_bullet, trajectory_of

        self.refuse_unused(params, predictor)

        run = simulate_bullet(scenario, duration=duration, params=params or self.param_sets[0], contacts=contacts)
        return EngineRun(trajectory_of(run, record_every), run.tables["contacts"] if contacts else None,
                         dict(run.summary), {"bullet_world.json": run.world})
