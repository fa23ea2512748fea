"""Scalar functions shared by several closures, written to be safe at I = 0, I = inf and I/I0 -> 0.

Sources: paper eqs ``mu(I)`` (Jop et al. 2006 friction law), ``F-mu(I)`` (the dilatancy function of
the mu(I) closure) and ``psi:mu(I)`` (Robinson closure). All are dimensionless.
"""
from __future__ import annotations

import numpy as np

#: Below this x = I/I0, H(x) and H'(x) are evaluated from their Taylor series (error < x^9).
SERIES_SWITCH = 1e-2
_SERIES_ORDER = 9


def mu_of_I(I, mu1: float, mu2: float, I0: float):
    """Friction law mu(I) = mu1 + (mu2 - mu1) / (1 + I0/I) [-] (paper eq. mu(I)); mu(0) = mu1,
    mu(inf) = mu2."""
    I = np.asarray(I, dtype=float)
    with np.errstate(invalid="ignore"):
        return mu1 + (mu2 - mu1) * np.where(np.isinf(I), 1.0, I / (I + I0))


def dmu_dI(I, mu1: float, mu2: float, I0: float):
    """mu'(I) = (mu2 - mu1) I0 / (I + I0)^2 [-]."""
    I = np.asarray(I, dtype=float)
    return (mu2 - mu1) * I0 / (I + I0) ** 2


_H_SERIES = np.array([-2.0, 0.5, 0.0] + [(-1) ** n * (n - 2) / (n + 1) for n in range(3, _SERIES_ORDER)])
"""Coefficients of x^0 .. x^8 of H's series: -2 + x/2 + 0 x^2 + sum_{n>=3} (-1)^n (n-2)/(n+1) x^n."""
_DH_SERIES = np.array([k * c for k, c in enumerate(_H_SERIES)][1:])
"""Coefficients of x^0 .. x^7 of H'(x), the term-by-term derivative."""


def _series_or_direct(x, series_coefficients, direct):
    """``polyval`` of the series (Horner) where ``x < SERIES_SWITCH``, ``direct(x)`` where x is
    larger and finite, 0 at x = inf (and NaN); each evaluated on its own cells only."""
    x = np.asarray(x, dtype=float)
    out = np.zeros(x.shape)
    small = x < SERIES_SWITCH
    if small.any():
        out[small] = np.polynomial.polynomial.polyval(x[small], series_coefficients)
    large = ~small & np.isfinite(x)
    if large.any():
        out[large] = direct(x[large])
    return out


def H(x):
    """H(x) = 1/(1+x) - 3 ln(1+x)/x (paper eq. F-mu(I)); H(0) = -2, H(inf) = 0.

    Uses log1p, and the series -2 + x/2 + sum_{n>=3} (-1)^n (n-2)/(n+1) x^n below
    ``SERIES_SWITCH``, so that there is no 0/0 at x = 0.
    """
    return _series_or_direct(x, _H_SERIES, lambda xl: 1.0 / (1.0 + xl) - 3.0 * np.log1p(xl) / xl)


def dH(x):
    """H'(x) = -1/(1+x)^2 - 3 [1/(x(1+x)) - ln(1+x)/x^2]; H'(0) = 1/2, H'(inf) = 0; series below
    ``SERIES_SWITCH``."""
    return _series_or_direct(
        x, _DH_SERIES, lambda xl: -1.0 / (1.0 + xl) ** 2 - 3.0 * (1.0 / (xl * (1.0 + xl)) - np.log1p(xl) / xl**2))


def F_mu(I, mu1: float, mu2: float, I0: float):
    """F(I) = mu2 + (mu2 - mu1)/2 H(I/I0) [-] (paper eq. F-mu(I)); F(0) = mu1, F(inf) = mu2.

    F = (3/(2I)) int_0^I mu - mu/2 is the W of eq. f-general for Z = mu(I).
    """
    return mu2 + 0.5 * (mu2 - mu1) * H(np.asarray(I, dtype=float) / I0)


def dF_mu(I, mu1: float, mu2: float, I0: float):
    """F'(I) = (mu2 - mu1)/(2 I0) H'(I/I0) [-]."""
    return 0.5 * (mu2 - mu1) / I0 * dH(np.asarray(I, dtype=float) / I0)


def robinson_h(x):
    """h(x) = 1/(1+x) + 2 ln(1+x), the rate-dependent part of Robinson's G (x = I/I0)."""
    x = np.asarray(x, dtype=float)
    return 1.0 / (1.0 + x) + 2.0 * np.log1p(x)


def robinson_G(I, mu1: float, mu2: float, I0: float):
    """G(I) = (2 mu1/3) ln(I/I0) + (mu2 - mu1)/3 h(I/I0) [-] (paper eq. psi:mu(I));
    G(0) = -inf, G(inf) = inf."""
    I = np.asarray(I, dtype=float)
    with np.errstate(divide="ignore"):
        return (2.0 * mu1 / 3.0) * np.log(I / I0) + (mu2 - mu1) / 3.0 * robinson_h(I / I0)


def robinson_dG(I, mu1: float, mu2: float, I0: float):
    """G'(I) = 2 mu1/(3 I) + (mu2 - mu1)/(3 I0) (2/(1+x) - 1/(1+x)^2), x = I/I0 [-]."""
    I = np.asarray(I, dtype=float)
    x = I / I0
    with np.errstate(divide="ignore"):
        return 2.0 * mu1 / (3.0 * I) + (mu2 - mu1) / (3.0 * I0) * (2.0 / (1.0 + x) - 1.0 / (1.0 + x) ** 2)
