"""Exceptions of learned_contact, all subclasses of testbed.errors.TestbedError."""

from __future__ import annotations

from testbed.errors import TestbedError


class PredictorInputError(TestbedError, ValueError):
    """Inputs to a predictor that it cannot answer: bad shapes, non-finite values or
    container sizes it was not trained for (the message lists the supported sizes)."""


class PredictorDomainError(PredictorInputError):
    """Poses outside the range the predictor answers (separated or deeply penetrating
    boxes), raised by `predict(..., outside="raise")`."""


class DatasetError(TestbedError, ValueError):
    """A dataset request that cannot be met (unknown distribution, bad size, ...)."""


class WeightsError(TestbedError):
    """A weights file that is missing, unreadable or of an unknown format version."""


class PredictorOutputError(TestbedError, ValueError):
    """A model's answers the bench cannot use: wrong shapes, NaN or infinite values, or
    normals further than learned_contact.external.NORMAL_LENGTH_TOLERANCE from unit
    length (the message names the model and counts the poses)."""
