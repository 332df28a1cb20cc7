"""Grid Convergence Index (Celik et al. 2008, J. Fluids Eng. 130(7) 078001; Roache 1994) of
one quantity on a sequence of truths, with every degenerate case stated, never divided by.

Three-rung sequence, f1 the finest, f3 the coarsest, constant refinement ratio r > 1:
  e21 = f2 - f1, e32 = f3 - f2
  observed order  p = |ln|e32 / e21|| / ln r
  GCI_fine        = Fs |e21| / (r^p - 1)        (absolute, in the quantity's unit)
                    / |f1|                       (relative, Celik's form; None when f1 = 0)
  Fs = 1.25 when p lies in [0.95, 2.05] (the sequence behaves like a first/second-order
  method), else 3.0, and the result says so.
Cases (the `behaviour` field):
  monotone     e32 and e21 of one sign and |e21| < |e32|: the GCI above; the absolute
               uncertainty is GCI_fine (= relative GCI x |f1|);
  oscillatory  e32 e21 < 0: the GCI with Fs 3.0; the ladder is not monotone, so the
               absolute uncertainty is |f_default - f_reference|, the larger of the two if
               the GCI is larger;
  divergent    one sign, |e21| >= |e32| (the differences do not shrink): as oscillatory;
  zero_fine    e21 = 0, e32 != 0 (the two finest agree): p is unbounded, no GCI; the
               uncertainty is |f_default - f_reference|;
  identical    e21 = e32 = 0: uncertainty 0;
  unavailable  a value is missing or not finite: uncertainty None.
"Zero" is |e| <= ZERO_TOL x max(|f1|, |f2|, |f3|) + tiny: a difference at the level of
floating-point noise is no evidence of convergence order.

Two-rung estimate (Roache's two-grid GCI), for a pair where the order is not observed
(the continuous plant at two error-control accuracies, r the accuracy ratio): an assumed
order p (1: the error of an error-controlled integrator is proportional to its accuracy)
with Fs 3.0: GCI = 3.0 |f1 - f2| / (r^p - 1).
"""

from __future__ import annotations

import math

FS_CONFIDENT = 1.25  # [-] safety factor when the observed order is plausible
FS_CAUTIOUS = 3.0  # [-] otherwise (and for two-rung estimates)
P_RANGE = (0.95, 2.05)  # observed orders taken as plausible
ZERO_TOL = 1e-12  # [-] relative size below which a difference counts as zero


def _finite(*values) -> bool:
    return all(v is not None and isinstance(v, (int, float)) and math.isfinite(v) for v in values)


def _zero(e: float, scale: float) -> bool:
    return abs(e) <= ZERO_TOL * scale + 1e-300


def gci3(f1, f2, f3, r: float = 2.0, *, f_default=None, f_reference=None) -> dict:
    """The GCI of the finest value f1 from the sequence f3 (coarsest) -> f2 -> f1, ratio r.

    f_default, f_reference: the values the 'not monotone' uncertainty compares (default:
    f3 and f1). Returns {'behaviour', 'p' (observed order or None), 'fs', 'gci_abs' [unit of
    f], 'gci_rel' [-] or None, 'uncertainty' [unit of f] or None, 'note' (one line)}."""
    f_default = f3 if f_default is None else f_default
    f_reference = f1 if f_reference is None else f_reference
    out = {"behaviour": "unavailable", "p": None, "fs": None, "gci_abs": None, "gci_rel": None,
           "uncertainty": None, "note": ""}
    if not _finite(f1, f2, f3) or not r > 1:
        out["note"] = "a rung's value is missing or not finite: no GCI"
        return out
    scale = max(abs(f1), abs(f2), abs(f3))
    e21, e32 = f2 - f1, f3 - f2
    spread = abs(f_default - f_reference) if _finite(f_default, f_reference) else None
    if _zero(e21, scale) and _zero(e32, scale):
        return {**out, "behaviour": "identical", "uncertainty": 0.0, "note": "all three rungs agree: uncertainty 0"}
    if _zero(e21, scale):
        return {**out, "behaviour": "zero_fine", "uncertainty": spread,
                "note": "the two finest rungs agree (f2 = f1) while the coarse one differs: observed order unbounded, "
                        "no GCI; uncertainty |f_default - f_reference|"}
    if _zero(e32, scale):
        p = None  # ln|0 / e21| is -inf: no order; the differences grew
        behaviour = "divergent"
    else:
        p = abs(math.log(abs(e32 / e21))) / math.log(r)
        behaviour = "oscillatory" if e32 * e21 < 0 else ("monotone" if abs(e21) < abs(e32) else "divergent")
    if behaviour == "monotone" and P_RANGE[0] <= p <= P_RANGE[1]:
        fs = FS_CONFIDENT
    else:
        fs = FS_CAUTIOUS
    gci_abs = fs * abs(e21) / (r ** p - 1.0) if p is not None and p > 0 else None
    gci_rel = gci_abs / abs(f1) if gci_abs is not None and not _zero(f1, scale) else None
    if behaviour == "monotone":
        uncertainty = gci_abs
        note = (f"monotone, observed order p = {p:.3g}, Fs {fs:g}"
                + ("" if fs == FS_CONFIDENT else f" (p outside [{P_RANGE[0]:g}, {P_RANGE[1]:g}])"))
    else:
        uncertainty = max(spread or 0.0, gci_abs or 0.0)
        what = {"oscillatory": "oscillatory (the differences change sign)",
                "divergent": "divergent (the differences do not shrink)"}[behaviour]
        note = (f"{what}" + (f", p = {p:.3g}" if p is not None else "") + f", Fs {fs:g}; "
                "uncertainty max(|f_default - f_reference|, GCI)")
    return {**out, "behaviour": behaviour, "p": p, "fs": fs, "gci_abs": gci_abs, "gci_rel": gci_rel,
            "uncertainty": uncertainty, "note": note}


def gci2(f1, f2, r: float, p_assumed: float = 1.0) -> dict:
    """Two-rung GCI of the finer value f1 from f2 (ratio r > 1) with an assumed order and Fs 3.0.
    Returns the gci3 fields; behaviour 'two_rung' (or 'identical' / 'unavailable')."""
    out = {"behaviour": "unavailable", "p": None, "fs": None, "gci_abs": None, "gci_rel": None,
           "uncertainty": None, "note": ""}
    if not _finite(f1, f2) or not r > 1:
        out["note"] = "a rung's value is missing or not finite: no GCI"
        return out
    scale = max(abs(f1), abs(f2))
    if _zero(f2 - f1, scale):
        return {**out, "behaviour": "identical", "uncertainty": 0.0, "note": "both rungs agree: uncertainty 0"}
    gci_abs = FS_CAUTIOUS * abs(f2 - f1) / (r ** p_assumed - 1.0)
    return {**out, "behaviour": "two_rung", "p": p_assumed, "fs": FS_CAUTIOUS, "gci_abs": gci_abs,
            "gci_rel": gci_abs / abs(f1) if not _zero(f1, scale) else None, "uncertainty": gci_abs,
            "note": f"two rungs: assumed order {p_assumed:g} (not observed), Fs {FS_CAUTIOUS:g}, ratio {r:g}"}
