"""Learned contact for container pairs: Drake-labelled data, the paper's MLP and an
improved predictor with a pure-numpy inference path.

Public API:
    from learned_contact import load_predictor
    pred = load_predictor()          # shipped default; load_predictor(path) for others
    point_A, normal_A = pred.predict(p_AB, R_AB, size_A=size_A, size_B=size_B)

Importing this package (and predicting) never imports torch or Drake; training
(learned_contact.training) needs torch, labelling (learned_contact.labels) needs Drake.
"""

from learned_contact.errors import PredictorDomainError, PredictorInputError, WeightsError
from learned_contact.predictor import ContactPredictor, load_predictor

__all__ = ["ContactPredictor", "PredictorDomainError", "PredictorInputError", "WeightsError", "load_predictor"]
