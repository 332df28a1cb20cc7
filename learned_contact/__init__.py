"""Learned contact for container pairs: Drake-labelled data, the paper's MLP and an
improved predictor, with compiled (numba) and numpy reference inference paths.

Public API:
    from learned_contact import load_predictor
    pred = load_predictor()          # "improved" (shipped); "paper", or a weights path
    point_A, normal_A = pred.predict(p_AB, R_AB, size_A=size_A, size_B=size_B)
    depth = pred.depth(p_AB, R_AB, size_A=size_A, size_B=size_B)
Every predictor answers learned_contact.interface.Predictor.

Importing this package (and predicting) never imports torch or Drake; training
(learned_contact.training) needs torch, labelling (learned_contact.labels) needs Drake.
"""

from learned_contact.errors import PredictorDomainError, PredictorInputError, WeightsError
from learned_contact.interface import Predictor
from learned_contact.loading import load_predictor
from learned_contact.predictor import ContactPredictor

__all__ = ["ContactPredictor", "Predictor", "PredictorDomainError", "PredictorInputError", "WeightsError",
           "load_predictor"]
