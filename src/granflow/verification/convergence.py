"""Mesh-convergence estimates of a sequence of refinement levels (Richardson extrapolation with
Roache's grid-convergence index; Roache 1998, *Verification and Validation in Computational
Science and Engineering*; Stern et al. 2001, J. Fluids Eng. 123, 793), shared by the validation
studies.
"""
from __future__ import annotations

import math

FORMAL_ORDER = 1.0
"""Order assumed when the observed one cannot be used (the scheme's formal order near fronts)."""
GCI_SAFETY_3, GCI_SAFETY_2 = 1.25, 3.0
"""GCI safety factors with an observed order (three levels) and with an assumed one."""
ORDER_RANGE = (0.5, 4.0)
"""Observed orders accepted for the three-level Richardson estimate."""


def richardson(values, ratio: float = 2.0) -> dict:
    """Extrapolated value and uncertainty from coarse-to-fine ``values`` (refinement ``ratio``).

    Three values: observed order p = ln((f1 - f2)/(f2 - f3))/ln r; if the differences have the
    same sign and p is in :data:`ORDER_RANGE`, f = f3 + (f3 - f2)/(r^p - 1) with uncertainty
    GCI = 1.25 |f3 - f2|/(r^p - 1) (Roache 1998). Otherwise (two values, or non-monotone / out-of-
    range order) the formal order 1 with safety factor 3: f = f_fine + (f_fine - f_prev)/(r - 1),
    uncertainty 3 |f_fine - f_prev|/(r - 1).
    """
    f = [float(v) for v in values]
    if len(f) >= 3:
        d1, d2 = f[-3] - f[-2], f[-2] - f[-1]
        if d1 * d2 > 0 and d2 != 0:
            p = math.log(d1 / d2) / math.log(ratio)
            if ORDER_RANGE[0] <= p <= ORDER_RANGE[1]:
                e = (f[-1] - f[-2]) / (ratio**p - 1)
                return {"value": f[-1] + e, "uncertainty": GCI_SAFETY_3 * abs(e), "order": p,
                        "method": "3-level Richardson"}
        label = "1st-order fallback"
        p_obs = math.log(abs(d1 / d2)) / math.log(ratio) if d1 * d2 > 0 and d2 != 0 else None
    elif len(f) == 2:
        label, p_obs = "2-level, 1st order assumed", None
    else:
        return {"value": f[-1] if f else math.nan, "uncertainty": math.nan, "order": None,
                "method": "single level"}
    e = (f[-1] - f[-2]) / (ratio**FORMAL_ORDER - 1)
    return {"value": f[-1] + e, "uncertainty": GCI_SAFETY_2 * abs(e), "order": p_obs, "method": label}


OSCILLATORY_HALF_RANGE = 0.5
"""Uncertainty of an oscillatory sequence as a fraction of the range of its three values (Stern et
al. 2001, J. Fluids Eng. 123, 793: half the range)."""
LEVELS_3 = 3
"""Levels of the three-level estimates."""


def mesh_estimate(values, ratio: float = 2.0) -> dict:
    """Mesh-converged value of coarse-to-fine ``values``: :func:`richardson` (3-level Richardson +
    GCI when monotone, first order otherwise), except for oscillatory convergence (three values
    whose differences change sign), where the finest value is kept and the uncertainty is half the
    range of the three (Stern et al. 2001, J. Fluids Eng. 123, 793). Same keys as
    :func:`richardson`."""
    f = [float(v) for v in values]
    if len(f) == LEVELS_3 and (f[0] - f[1]) * (f[1] - f[2]) < 0:
        return {"value": f[-1], "uncertainty": OSCILLATORY_HALF_RANGE * (max(f) - min(f)), "order": None,
                "method": "oscillatory: finest, +- half range"}
    return richardson(f, ratio)


def ratio_estimate(numerator: dict, denominator: dict) -> dict:
    """Ratio of two estimates (:func:`mesh_estimate` dicts); relative uncertainties add (a bound:
    it does not assume the two errors independent)."""
    r = numerator["value"] / denominator["value"]
    rel = (numerator["uncertainty"] / abs(numerator["value"])
           + denominator["uncertainty"] / abs(denominator["value"]))
    return {"value": r, "uncertainty": abs(r) * rel}
