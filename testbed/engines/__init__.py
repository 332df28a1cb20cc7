"""Other simulators run on the testbed's scenes, judged against Drake's ground truth.

One module per engine; none is imported by `import testbed` (each imports its engine's
package only when called, and reports a missing one with the install command).

  mujoco.py          Scenario -> MJCF -> MjModel, with MuJoCo's default contact
                     parameters or a set matched to Drake's hydroelastic contact
  mujoco_run.py      simulate_mujoco: steps a translated scene, records the Drake-shaped
                     `steps` and per-pair `contacts` tables and the wall time;
                     sampled_run_mujoco: the simulation study's sampled_run for MuJoCo
  mujoco_crane.py    the crane effect's ropes and twistlocks as MuJoCo applied forces
  mujoco_compare.py  compare_mujoco (`testbed compare SCENE --engine mujoco`) and
                     engine_table_row (Drake once, both MuJoCo sets: the validate table)
"""
