"""The learned closed loop as one effect package: the effect and its system (effect.py),
its force law and stiffness fit (force_law.py), its per-step contact step (step.py: the native
core's, shared with the MuJoCo host),
the shadow truth it is compared with (truth.py). README.md beside them derives the law.

Importing the package registers the effect (testbed.effects' registry imports every
module and package of testbed/effects/).
"""

from testbed.effects.learned_dynamics import effect  # noqa: F401  (registers the effect)
