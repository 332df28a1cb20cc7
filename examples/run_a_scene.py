"""The Python API: load a shipped scene, change it, run it, read the figures; then a yard
written in a few lines. Run: python examples/run_a_scene.py (about 20 s)."""

import numpy as np

from testbed import load_scenario, run_scenario

# A shipped scene by name, with the same overrides `--set` takes on the command line.
scenario = load_scenario("two_stack", overrides=["containers[1].mass=12000"])
result = run_scenario(scenario, duration=0.3)
steps = result.tables["steps"]  # time (n,) [s], p_WB (n, m, 3) [m], q_WB (n, m, 4), V_WB (n, m, 6), energies
top = [c.name for c in scenario.containers].index("top")
drop_mm = (steps["p_WB"][0, top, 2] - steps["p_WB"][-1, top, 2]) * 1e3
print(f"two_stack, top box 12 t: settles {drop_mm:.3f} mm in {steps['time'][-1]:g} s; deepest penetration "
      f"{result.summary['max_penetration_m'] * 1e3:.3f} mm; {result.summary['ms_per_sim_second']:.0f} ms of wall "
      "time per simulated second")

# A yard block: rows x bays x tiers of 40 ft containers, expanded into ordinary containers.
yard = load_scenario(text="""
name: my_yard
duration: 0.1
yards:
- {name: blk, type: 1AA, rows: 2, bays: 3, tiers: 2, masses: [24000, 12000]}
effects: {contact: {model: point}, friction: {}, contact_log: {}}
""")
print(f"my_yard: {len(yard.containers)} containers, e.g. {yard.containers[0].name}")
steps = run_scenario(yard).tables["steps"]
moved = np.abs(steps["p_WB"][-1] - steps["p_WB"][0]).max()
print(f"my_yard at rest: the largest displacement in {steps['time'][-1]:g} s is {moved * 1e3:.2f} mm")
