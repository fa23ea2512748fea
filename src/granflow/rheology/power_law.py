"""Power-law yield functions Z = sum_k c_k I^(n_k) and their dilatancy functions (paper Table 1).

For Z = I^n (n != -1) eq. f-general gives
    f = (2 - n)/(2(n + 1)) (I^n - I_eq^(n+1)/I)                                       (Table 1)
and by linearity of Z -> f any linear combination works. Exponents must exceed -1 so that the
integral in W converges at 0 and the divergence law stays finite as |S| -> 0.
Z = I^2 gives f = 0 (a purely viscous stress d^2 rho_s |S| S, Remark rem-viscous3); n > 2 gives a
negative f coefficient and a negative dissipation at small I (Remark rem-viscous3).
"""
from __future__ import annotations

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
        return zip(self.exponents, self.coefficients)

    @staticmethod
    def _pow(I, n):
        I = _arr(I)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(I == 0, 1.0 if n == 0 else (0.0 if n > 0 else np.inf), I**n)

    def Z(self, phi, I):
        shape = np.broadcast(_arr(phi), _arr(I)).shape
        return sum((c * self._pow(I, n) for n, c in self._terms()), np.zeros(shape))

    def dZ_dI(self, phi, I):
        shape = np.broadcast(_arr(phi), _arr(I)).shape
        return sum((c * n * self._pow(I, n - 1) for n, c in self._terms() if n != 0), np.zeros(shape))

    def dZ_dphi(self, phi, I):
        return np.zeros(np.broadcast(_arr(phi), _arr(I)).shape)

    def A(self, phi, I):
        shape = np.broadcast(_arr(phi), _arr(I)).shape
        return sum((c * table1_coefficient(n) * self._pow(I, n) for n, c in self._terms()), np.zeros(shape))

    def dA_dI(self, phi, I):
        shape = np.broadcast(_arr(phi), _arr(I)).shape
        return sum(
            (c * table1_coefficient(n) * n * self._pow(I, n - 1) for n, c in self._terms() if n != 0),
            np.zeros(shape),
        )

    def dA_dphi(self, phi, I):
        return np.zeros(np.broadcast(_arr(phi), _arr(I)).shape)

    def B(self, phi):
        Ieq = np.maximum(self.I_eq(phi), 0.0)
        return sum((c * table1_coefficient(n) * Ieq ** (n + 1) for n, c in self._terms()), np.zeros_like(Ieq))

    def dB_dphi(self, phi):
        Ieq = np.maximum(self.I_eq(phi), 0.0)
        dIeq = np.where(self.I_eq(phi) > 0, self.equilibrium.dI_eq_dphi(phi), 0.0)
        return sum(
            (c * table1_coefficient(n) * (n + 1) * Ieq**n * dIeq for n, c in self._terms()),
            np.zeros_like(Ieq),
        )
