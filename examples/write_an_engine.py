"""Writing an engine: another simulator behind the Engine protocol (testbed/engines/base.py).
A shipped engine is one package of testbed/engines/; a script may register its own, as here.
This toy engine drops free containers straight down onto a penalty floor (no rotation, no
container-container contact): it refuses every scene it cannot simulate, and answers the
others with the Trajectory every comparison reads. Run: python examples/write_an_engine.py."""

import time

import numpy as np

from testbed.bodies.containers import CONTAINER_TYPES
from testbed.engines import Engine, EngineRun, UnsupportedSceneError, engine, register
from testbed.physics import GRAVITY
from testbed.simulation import Trajectory


@register
class FallingBoxes(Engine):
    name = "falling_boxes"
    label = "falling boxes (example)"
    stiffness = 5e8  # [N/m] of the floor per container
    damping = 2e6  # [N s/m]

    def check(self, scenario):
        free = [c for c in scenario.containers if not c.fixed]
        if len(free) != 1:
            raise UnsupportedSceneError(scenario.name, "containers", f"holds {len(free)} free containers; this engine "
                                        "simulates one")

    def run(self, scenario, *, duration=None, record_every=1, params=None, contacts=False, source="<scenario>"):
        self.check(scenario)
        box = next(c for c in scenario.containers if not c.fixed)
        h, m = scenario.plant.time_step, box.total_mass()
        half = 0.5 * CONTAINER_TYPES[box.type].size[2]
        z, v = float(box.pose().translation()[2]), 0.0
        n = int(round((duration or scenario.duration) / h))
        rows, start = [], time.perf_counter()
        for step in range(n + 1):
            if step % record_every == 0:
                rows.append((step * h, z, v))
            force = -m * GRAVITY + max(0.0, self.stiffness * (half - z) - self.damping * v)  # floor pushes only
            v += h * force / m  # semi-implicit Euler
            z += h * v
        t, zs, vs = (np.array(c) for c in zip(*rows))
        p_WB = np.zeros((len(t), 1, 3))
        p_WB[:, 0, :2], p_WB[:, 0, 2] = box.pose().translation()[:2], zs
        V_WB = np.zeros((len(t), 1, 6))
        V_WB[:, 0, 5] = vs
        potential = m * GRAVITY * zs
        trajectory = Trajectory(time=t, p_WB=p_WB, q_WB=np.tile([1.0, 0, 0, 0], (len(t), 1, 1)), V_WB=V_WB,
                                energy=potential + 0.5 * m * vs**2, potential=potential,
                                wall_s=time.perf_counter() - start, simulated_s=float(t[-1]), names=(box.name,))
        return EngineRun(trajectory, summary={"wall_per_sim_s": trajectory.wall_s / max(trajectory.simulated_s, 1e-12)})


if __name__ == "__main__":
    from testbed import load_scenario, run_scenario

    scenario = load_scenario("single_drop")
    mine = engine("falling_boxes").run(scenario, duration=1.0).trajectory
    drake = run_scenario(scenario, duration=1.0).tables["steps"]
    print(f"single_drop after 1 s: falling boxes z = {mine.p_WB[-1, 0, 2]:.4f} m, Drake z = {drake['p_WB'][-1, 0, 2]:.4f} m")
    try:
        engine("falling_boxes").check(load_scenario("two_stack"))
    except UnsupportedSceneError as error:
        print(f"refused: {error}")
