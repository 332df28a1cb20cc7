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
"""
