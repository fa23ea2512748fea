"""The generic closure: any user-supplied Z(phi, I), f derived symbolically (paper eq. f-general).

SymPy (:mod:`granflow.rheology.derive`) is imported when a generic closure is made, not when the
closure registry is: ``granflow list closures`` and ``import granflow`` do not pay for it.
"""
from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from pydantic import Field, PrivateAttr, field_validator

from granflow.rheology.base import CLOSURES, Closure, _arr


def _lambdify(expr):
    import sympy as sp

    from granflow.rheology.derive import I, phi

    fn = sp.lambdify((phi, I), expr, modules="numpy")

    def call(ph, ii):
        ph, ii = np.broadcast_arrays(_arr(ph), _arr(ii))
        with np.errstate(all="ignore"):
            return np.asarray(fn(ph, ii), dtype=float) + np.zeros(ph.shape)

    return call


@CLOSURES.register("generic")
class Generic(Closure):
    """Yield function given as an expression in ``phi`` and ``I``; f from eq. f-general.

    Attributes
    ----------
    expression : str
        Z(phi, I), e.g. ``"0.38 + 0.27*I/(I + 0.3)"`` (that is mu(I)). Default ``"0.4 + 0.2*I"``.
    """

    summary: ClassVar[str] = "user-supplied Z(phi, I); f derived by eq. f-general"
    source: ClassVar[str] = "f-general"
    expression: str = Field("0.4 + 0.2*I", description="yield function Z(phi, I) [-]")

    _fns: dict[str, Any] = PrivateAttr(default_factory=dict)

    @field_validator("expression")
    @classmethod
    def _parsable(cls, text: str) -> str:
        """Reject an unparsable expression here, so that the error names the key ``expression``."""
        from granflow.rheology.derive import parse_yield_function

        parse_yield_function(text)  # GranflowInputError is a ValueError: reported at this key
        return text

    def model_post_init(self, __context: Any) -> None:
        import sympy as sp

        from granflow.rheology.derive import I, derive_dilatancy, parse_yield_function, phi

        Zs = parse_yield_function(self.expression)
        d = derive_dilatancy(Zs, simplify=False)
        W = d.W
        exprs = {
            "Z": Zs,
            "dZ_dI": sp.diff(Zs, I),
            "dZ_dphi": sp.diff(Zs, phi),
            "W": W,
            "dW_dI": sp.diff(W, I),
            "dW_dphi": sp.diff(W, phi),
        }
        self._fns = {k: _lambdify(v) for k, v in exprs.items()}
        # Limits at I = 0 and I = inf, where the lambdified forms are 0/0 or inf/inf.
        for k in ("Z", "W"):
            for where, val in (("0", 0), ("inf", sp.oo)):
                lim = sp.limit(exprs[k], I, val)
                self._fns[f"{k}@{where}"] = _lambdify(lim) if lim.is_finite is not False else (
                    lambda ph, ii, s=float(np.sign(float(lim)) * np.inf) if lim in (sp.oo, -sp.oo) else np.nan:
                    np.full(np.broadcast(_arr(ph), _arr(ii)).shape, s)
                )
        self._fns["derivation"] = d

    @property
    def derivation(self):
        """The symbolic :class:`~granflow.rheology.derive.Derivation`."""
        return self._fns["derivation"]

    def _eval(self, key: str, phi_, I_):
        ph, ii = np.broadcast_arrays(_arr(phi_), _arr(I_))
        out = self._fns[key](ph, ii)
        if key in ("Z", "W"):
            out = np.where(ii == 0, self._fns[f"{key}@0"](ph, ii), out)
            out = np.where(np.isinf(ii), self._fns[f"{key}@inf"](ph, ii), out)
        return out

    def Z(self, phi_, I_):
        return self._eval("Z", phi_, I_)

    def dZ_dI(self, phi_, I_):
        return self._eval("dZ_dI", phi_, I_)

    def dZ_dphi(self, phi_, I_):
        return self._eval("dZ_dphi", phi_, I_)

    def A(self, phi_, I_):
        return self._eval("W", phi_, I_)

    def dA_dI(self, phi_, I_):
        return self._eval("dW_dI", phi_, I_)

    def dA_dphi(self, phi_, I_):
        return self._eval("dW_dphi", phi_, I_)

    def _clipped_I_eq(self, phi_):
        """I_eq clipped at 0 (phi >= phi_max), as for the power-law closure: Z need not be defined
        at negative I."""
        return np.maximum(self.I_eq(phi_), 0.0)

    def B(self, phi_):
        Ieq = self._clipped_I_eq(phi_)
        with np.errstate(invalid="ignore"):
            return np.where(Ieq == 0, 0.0, Ieq * self._eval("W", phi_, Ieq))

    def dB_dphi(self, phi_):
        Ieq = self._clipped_I_eq(phi_)
        dIeq = self.equilibrium.dI_eq_dphi(phi_)
        with np.errstate(invalid="ignore"):
            W = self._eval("W", phi_, Ieq)
            d = (W + Ieq * self._eval("dW_dI", phi_, Ieq)) * dIeq + Ieq * self._eval("dW_dphi", phi_, Ieq)
        return np.where(Ieq == 0, 0.0, d)
