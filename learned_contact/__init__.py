"""Learned contact for container pairs: Drake-labelled data, the paper's MLP and an
improved predictor, with compiled (the native C core, native/) and numpy reference inference paths.

Public API:
    from learned_contact import load_predictor
    pred = load_predictor()          # "improved" (shipped); "paper", a weights .npz, an ONNX
                                     # model (.onnx) or a Python factory (module:attribute)
    point_A, normal_A = pred.predict(p_AB, R_AB, size_A=size_A, size_B=size_B)
    depth = pred.depth(p_AB, R_AB, size_A=size_A, size_B=size_B)
Every predictor answers learned_contact.interface.Predictor; learned_contact.sources is
the catalogue of sources.

Importing this package (and predicting) never imports torch or Drake; training
(learned_contact.training.train) needs torch, labelling (learned_contact.data.labels) needs Drake.
"""

from learned_contact.errors import PredictorDomainError, PredictorInputError, PredictorOutputError, WeightsError
from learned_contact.interface import Predictor
from learned_contact.predictors.improved import ContactPredictor
from learned_contact.sources import load_predictor

__all__ = ["ContactPredictor", "Predictor", "PredictorDomainError", "PredictorInputError", "PredictorOutputError",
           "WeightsError", "load_predictor"]
