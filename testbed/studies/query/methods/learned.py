"""Query-study methods of the learned models: the paper's MLP and the improved predictor.

- paper_mlp_single / paper_mlp_batched: the paper-faithful 6-20-18-4 tanh MLP,
  learned_contact.load_predictor("paper"), one pair per call / all pairs per call;
- improved_single / improved_batched: learned_contact.load_predictor("improved");
- <label>_single / <label>_batched for each of MethodOptions.extra_predictors (any
  learned_contact.sources string: an ONNX model, a Python object, a weights file).
Both answer learned_contact.interface.Predictor; weights are decoded there, not here.
Missing or unreadable weights mark the methods unavailable, with the reason.
"""

from __future__ import annotations

from learned_contact import sources
from learned_contact.predictors.paper import decode_paper, predict_paper
from testbed.studies.query.methods.base import ContactMethod

ORDER = 40
MODELS = (  # method name prefix, label, load_predictor name, MethodOptions field with a weights path
    ("paper_mlp", "paper MLP 6-20-18-4", "paper", "paper_weights"),
    ("improved", "improved predictor", "improved", "predictor"),
)


def paper_predict(mlp, p_AB, R_AB, size_A):
    """The paper MLP's answer for poses p_AB (n, 3) [m], R_AB (n, 3, 3), size_A (n, 3)
    or (3,) [m]: (point (n, 3) [m] on A's surface, normal (n, 3) unit A->B) in A's frame
    (mlp: a learned_contact.model.mlp.NumpyMLP; decoding: learned_contact.predictors.paper)."""
    return decode_paper(predict_paper(mlp, p_AB, R_AB), p_AB, size_A)


def build(poses, scenes, options) -> list[ContactMethod]:
    """The paper MLP's and the improved predictor's methods (and those of any extra
    predictor), one pair per call and batched."""
    P, R, SA, SB = poses.p_AB, poses.R_AB, poses.size_A, poses.size_B
    methods = []
    models = [(prefix, label, getattr(options, field) or name) for prefix, label, name, field in MODELS]
    models += [(f"bench_{sources.label(spec)}", f"{sources.label(spec)} ({sources.source_of(spec).key})", spec)
               for spec in options.extra_predictors]
    for prefix, label, spec in models:
        try:
            predictor = sources.load_predictor(spec)
        except Exception as exc:  # noqa: BLE001 - missing or unreadable weights: report, go on
            methods += [ContactMethod(f"{prefix}_{kind}", f"{label}, {how}", "learned", False, f"{type(exc).__name__}: {exc}")
                        for kind, how in (("single", "one pair per call"), ("batched", "batched"))]
            continue
        methods.append(ContactMethod(f"{prefix}_single", f"{label}, one pair per call", "learned",
                                     single=_single(predictor, P, R, SA, SB)))
        methods.append(ContactMethod(f"{prefix}_batched", f"{label}, batched", "learned",
                                     batched=lambda p=predictor: p.predict(P, R, size_A=SA, size_B=SB)))
    return methods


def _single(predictor, P, R, SA, SB):
    def single(i):
        point, normal = predictor.predict(P[i], R[i], size_A=SA[i], size_B=SB[i])
        return point, normal, None

    return single
