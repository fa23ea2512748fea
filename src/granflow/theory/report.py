"""Report objects of the condition checker (:mod:`granflow.theory.conditions`): the condition
keys, their statements, and JSON / plain-text rendering."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import Enum
from typing import Any

import numpy as np


class Condition(str, Enum):
    """The conditions checked, by report key."""

    C1 = "C1"
    C2 = "C2"
    C2_STRICT = "C2_strict"
    C3 = "C3"
    DISSIPATION = "dissipation"
    EQUILIBRIUM = "equilibrium"
    Z_NONNEGATIVE = "Z_nonnegative"


DESCRIPTIONS: dict[Condition, str] = {
    Condition.C1: "Z - (I/2) dZ/dI = f + I df/dI (eq. C1)",
    Condition.C2: "Z + I dZ/dI >= 0 (eq. C2, the paper's relaxed form)",
    Condition.C2_STRICT: "dZ/dI > 0 (Barker et al. 2017)",
    Condition.C3: "df/dp - (I/(2p)) df/dI < 0 (eq. C3); margin I df/dI - 2p df/dp > 0",
    Condition.DISSIPATION: "Z >= f (eq. dissipation-general)",
    Condition.EQUILIBRIUM: "f(I_eq) = 0, f > 0 for I > I_eq, f < 0 for I < I_eq (Theorem th2)",
    Condition.Z_NONNEGATIVE: "Z >= 0",
}
#: Name of the worst-value key of each condition in the report.
WORST_KEY: dict[Condition, str] = {c: ("max_residual" if c is Condition.C1 else "min_margin") for c in Condition}
_CONDS = tuple(Condition)


def _num(x) -> float | None:
    """Plain float, or None for NaN / inf / None."""
    x = None if x is None else float(x) + 0.0  # + 0.0 turns -0.0 into 0.0
    return x if x is not None and math.isfinite(x) else None


def _clean(obj):
    """Recursively turn numpy scalars / tuples into JSON-ready Python objects (NaN -> None)."""
    if isinstance(obj, dict):
        return {str(k.value if isinstance(k, Enum) else k): _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple, np.ndarray)):
        return [_clean(v) for v in obj]
    if isinstance(obj, Enum):
        return _clean(obj.value)
    for types, conv in (((bool, np.bool_), bool), ((int, np.integer), int), ((float, np.floating), _num)):
        if isinstance(obj, types):
            return conv(obj)
    return obj




@dataclass
class ConditionResult:
    """Verdict of one condition over the grid.

    ``passed`` is True when no finite grid point fails; ``worst_value`` is the max relative residual
    (C1) or the min margin (the others), located by ``worst_point`` (phi, p, I_eq, I, r, value);
    ``fails_where`` lists the failing regions (intervals of r = I/I_eq and of I, phi and p ranges,
    refined boundaries per phi); ``n_not_finite`` counts the points skipped because the closure is
    not finite; ``extra`` holds ``max_abs_residual`` (C1) or ``max_abs_f_at_eq`` (equilibrium);
    ``note`` explains degenerate failures (a strict inequality on a quantity that is 0).
    """

    condition: Condition
    passed: bool
    worst_value: float | None
    worst_point: dict | None
    fails_where: list[dict]
    n_points: int
    n_not_finite: int
    extra: dict[str, Any] = field(default_factory=dict)
    note: str | None = None

    def to_dict(self) -> dict[str, Any]:
        d = {"pass": self.passed, WORST_KEY[self.condition]: self.worst_value, "worst_point": self.worst_point,
             "fails_where": self.fails_where, "description": DESCRIPTIONS[self.condition],
             "n_points": self.n_points, "n_not_finite": self.n_not_finite, **self.extra, "note": self.note}
        return _clean(d)


@dataclass
class CheckReport:
    """Result of :func:`check`; ``to_dict()`` is JSON-ready, ``summary_table()`` readable text."""

    closure: str
    reference: bool
    parameters: dict[str, Any]
    conditions: dict[str, ConditionResult]
    grid: dict[str, Any]
    tolerances: dict[str, float]
    not_finite: list[dict]

    @property
    def passed(self) -> bool:
        """True when every condition passes."""
        return all(c.passed for c in self.conditions.values())

    def failed(self) -> list[str]:
        """Keys of the failing conditions."""
        return [k for k, c in self.conditions.items() if not c.passed]

    def to_dict(self) -> dict[str, Any]:
        return _clean({
            "closure": self.closure, "reference": self.reference, "parameters": self.parameters,
            "conditions": {k: c.to_dict() for k, c in self.conditions.items()},
            "grid": self.grid, "tolerances": self.tolerances, "not_finite": self.not_finite,
        })

    def summary_table(self) -> str:
        """Plain-text table: one line per condition (holds?, worst value, where it fails)."""
        params = ", ".join(f"{k}={v}" for k, v in _clean(self.parameters).items())
        lines = [f"closure {self.closure}" + (" (reference)" if self.reference else "") + f": {params}"]
        head = f"{'condition':<14} {'holds':<5} {'worst value':<26} where it fails"
        lines += [head, "-" * len(head)]
        for key, c in self.conditions.items():
            worst = f"{WORST_KEY[c.condition]} = {_fmt(c.worst_value)}"
            where = "; ".join(_describe_region(r) for r in c.fails_where) or "-"
            if c.n_not_finite:
                where += f" [{c.n_not_finite} points not finite, skipped]"
            lines.append(f"{key:<14} {'yes' if c.passed else 'NO':<5} {worst:<26} {where}")
            if c.note:
                lines.append(f"{'':<14} {'':<5} note: {c.note}")
        if self.not_finite:
            lines.append("closure not finite at: " + "; ".join(_describe_region(r) for r in self.not_finite))
        return "\n".join(lines)


def _fmt(x) -> str:
    return "n/a" if x is None or not math.isfinite(x) else f"{x:.4g}"


def _describe_region(reg: dict) -> str:
    def interval(name, iv):
        lo = ("<=" if reg["open_below"] else "") + _fmt(iv[0])
        hi = _fmt(iv[1]) + ("(+)" if reg["open_above"] else "")
        return f"{name} in [{lo}, {hi}]"

    if reg["covers_grid"]:
        txt = "everywhere"
    elif reg["r_interval"] is not None:
        txt = interval("I/I_eq", reg["r_interval"])
    else:
        txt = interval("I", reg["I_interval"])
    ph = reg["phi_range"]
    txt += f" (phi {_fmt(ph[0])}" + (f"-{_fmt(ph[1])})" if ph[1] != ph[0] else ")")
    return txt
