"""The learned closed loop as one effect package: the effect and its system (effect.py),
its force law and stiffness fit (force_law.py), its per-step contact step (step.py: the native
core's, shared with the MuJoCo host), the static contact answer the law applies at a pose
(static.py: static_contact), the shadow truth it is compared with (truth.py). README.md beside
them derives the law.

Importing the package registers the effect (testbed.effects' registry imports every
module and package of testbed/effects/).
"""

from testbed.effects.learned_dynamics import effect  # noqa: F401  (registers the effect)
from testbed.effects.learned_dynamics.static import static_contact  # noqa: F401  (the public answer)
