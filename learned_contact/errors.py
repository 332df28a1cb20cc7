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
    normals further than learned_contact.predictors.external.NORMAL_LENGTH_TOLERANCE from unit
    length (the message names the model and counts the poses)."""


def weights_error(path, field: str, problem: str) -> WeightsError:
    """The WeightsError for testbed.safe_files' checks of a weights .npz (`error=` builder):
    one line naming the file, the field when there is one, and the problem."""
    return WeightsError(f"cannot read weights file {path}: {field + ' ' if field else ''}{problem}")


def onnx_file_error(path, field: str, problem: str) -> WeightsError:
    """The same for an ONNX model file."""
    return WeightsError(f"ONNX model {path}: {field + ' ' if field else ''}{problem}")


class PredictorTimeoutError(PredictorOutputError):
    """A model's call that ran past learned_contact.predictors.limits' call_timeout_s and was stopped
    (the message names the model and the bound's flag)."""
