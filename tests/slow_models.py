"""Python models whose time goes where the model bounds must tell apart, for
tests/learned/test_limits_watchdog.py: the testbed's own work inside a model's load or call
(never counted against its bound) against the model's own slowness (always counted).

Importable as `slow_models` when tests/ is on sys.path. Every model answers like the
centre-line model (point_A = p_AB / 2 [m], normal_A = p_AB / |p_AB|), in numpy, which passes
the load-time probe in milliseconds.
"""

from __future__ import annotations

import time

import numpy as np

from learned_contact import load_predictor
from learned_contact.predictors import limits

SLEEP_S = 2.0  # [s] how long each slow part takes; the tests set bounds well below it


class CentreLine:
    """The centre-line model in numpy: fast and consistent."""

    name = "centre line (numpy)"

    def predict(self, p_AB, R_AB, *, size_A, size_B):
        p = np.asarray(p_AB, dtype=float)
        return 0.5 * p, p / np.linalg.norm(p, axis=1, keepdims=True)


class SleepsInCall(CentreLine):
    """Sleeps SLEEP_S in every call: the model's own time, stopped by the call bound."""

    def predict(self, p_AB, R_AB, *, size_A, size_B):
        time.sleep(SLEEP_S)
        return super().predict(p_AB, R_AB, size_A=size_A, size_B=size_B)


class ShippedThenSleeps(SleepsInCall):
    """Loads the shipped predictor in its factory (the testbed's own work), then sleeps in every
    call (its own): the pause for the first must not excuse the second."""

    def __init__(self):
        self._shipped = load_predictor("improved")
        self.supported_sizes = self._shipped.supported_sizes


def own_work_then_model() -> CentreLine:
    """A factory whose SLEEP_S is the testbed's own work (limits.project_work)."""
    with limits.project_work():
        time.sleep(SLEEP_S)
    return CentreLine()


def slow_factory() -> CentreLine:
    """A factory that itself takes SLEEP_S: the model's own time."""
    time.sleep(SLEEP_S)
    return CentreLine()


SLOW_START_UP = f'''"""A slow interpreter start-up (as a cold kernel cache or a busy machine makes it): not the model's time."""
import time
time.sleep({SLEEP_S})
'''
