"""Power-law yield functions Z = sum_k c_k I^(n_k) and their dilatancy functions (paper Table 1).

For Z = I^n (n != -1) eq. f-general gives
    f = (2 - n)/(2(n + 1)) (I^n - I_eq^(n+1)/I)                                       (Table 1)
and by linearity of Z -> f any linear combination works. Exponents must exceed -1 so that the
integral in W converges at 0 and the divergence law stays finite as |S| -> 0.
Z = I^2 gives f = 0 (a purely viscous stress d^2 rho_s |S| S, Remark rem-viscous3); n > 2 gives a
negative f coefficient and a negative dissipation at small I (Remark rem-viscous3).
"""
from __future__ import annotations

import math
from typing import ClassVar

import numpy as np
from pydantic import Field, model_validator

from granflow.rheology.base import CLOSURES, Closure, _arr


def table1_coefficient(n):
    """c(n) = (2 - n) / (2 (n + 1)), the factor of Table 1 [-]."""
    return (2.0 - n) / (2.0 * (n + 1.0))


@CLOSURES.register("power_law")
class PowerLaw(Closure):
    """Z(I) = sum_k coefficients[k] * I**exponents[k] (paper Table 1 and its linear combinations).

    Attributes
    ----------
    exponents : tuple of float
        Exponents n_k > -1 [-]. Default (0, 1).
    coefficients : tuple of float
        Coefficients c_k [-], same length. Default (0.4, 0.2): Z = 0.4 + 0.2 I.
    """

    summary: ClassVar[str] = "Z = sum c_k I^n_k, f from Table 1"
    source: ClassVar[str] = "f-general, Table tab:1"

    exponents: tuple[float, ...] = Field((0.0, 1.0), min_length=1, description="exponents n_k > -1 [-]")
    coefficients: tuple[float, ...] = Field((0.4, 0.2), min_length=1, description="coefficients c_k [-]")

    @model_validator(mode="after")
    def _check(self):
        if len(self.exponents) != len(self.coefficients):
            raise ValueError(
                f"exponents ({len(self.exponents)}) and coefficients ({len(self.coefficients)}) "
                "must have the same length"
            )
        bad = [n for n in self.exponents if not n > -1]
        if bad:
            raise ValueError(f"exponents must exceed -1, got {bad}")
        return self

    def _terms(self):
        """(n_k, c_k) of Z, without zero coefficients (0 * I^n would be NaN at I = inf)."""
        return [(n, c) for n, c in zip(self.exponents, self.coefficients) if c != 0]

    def _f_terms(self):
        """(n_k, c_k (2 - n_k)/(2(n_k + 1))) of A = W, without the zero ones (n = 2 gives f = 0:
        Remark rem-viscous3; keeping it would give 0 * inf = NaN at I = inf, i.e. at p = 0)."""
        return [(n, c * table1_coefficient(n)) for n, c in self._terms() if table1_coefficient(n) != 0]

    @staticmethod
    def _limit(terms, at_infinity: bool) -> float:
        """Value of sum k I^n at I = inf (or I = 0): the dominant power's sign times inf, or the
        constant term when no power grows there (avoids inf - inf and 0 * inf)."""
        by_power: dict[float, float] = {}
        for n, k in terms:
            by_power[n] = by_power.get(n, 0.0) + k
        growing = sorted((n for n in by_power if (n > 0) == at_infinity and n != 0),
                         key=abs, reverse=True)
        for n in growing:
            if by_power[n] != 0:
                return math.copysign(math.inf, by_power[n])
        return by_power.get(0.0, 0.0)

    def _series(self, terms, phi, I):
        """sum_k k I^n over terms (n, k), vectorised, exact limits at I = 0 and I = inf."""
        shape = np.broadcast(_arr(phi), _arr(I)).shape
        I = np.broadcast_to(_arr(I), shape)
        ends = (I == 0) | (I == np.inf)
        Ir = np.where(ends, 1.0, I)  # NaN (and negative I with fractional powers) stay NaN
        total = sum((k * Ir**n for n, k in terms), np.zeros(shape))
        return np.where(I == 0, self._limit(terms, at_infinity=False),
                        np.where(I == np.inf, self._limit(terms, at_infinity=True), total))

    def Z(self, phi, I):
        return self._series(self._terms(), phi, I)

    def dZ_dI(self, phi, I):
        return self._series([(n - 1, c * n) for n, c in self._terms() if n != 0], phi, I)

    def dZ_dphi(self, phi, I):
        return np.zeros(np.broadcast(_arr(phi), _arr(I)).shape)

    def A(self, phi, I):
        return self._series(self._f_terms(), phi, I)

    def dA_dI(self, phi, I):
        return self._series([(n - 1, k * n) for n, k in self._f_terms() if n != 0], phi, I)

    def dA_dphi(self, phi, I):
        return np.zeros(np.broadcast(_arr(phi), _arr(I)).shape)

    def B(self, phi):
        """B = sum_k c_k c(n_k) I_eq^(n_k+1), I_eq clipped at 0; exact limit where I_eq = inf."""
        Ieq = np.maximum(self.I_eq(phi), 0.0)
        return self._series([(n + 1, k) for n, k in self._f_terms()], phi, Ieq)

    def dB_dphi(self, phi):
        Ieq = np.maximum(self.I_eq(phi), 0.0)
        dIeq = self.equilibrium.dI_eq_dphi(phi)
        with np.errstate(invalid="ignore"):
            d = self._series([(n, k * (n + 1)) for n, k in self._f_terms()], phi, Ieq) * dIeq
        return np.where(Ieq == 0, 0.0, d)
