"""Barker et al. (2015) well-posedness criterion of the incompressible mu(I) rheology.

Source: Barker, Schaeffer, Bohorquez & Gray (2015), J. Fluid Mech. 779, 794-818; MODEL.md §7.
The incompressible model div u = 0, tau = mu(I) p S/|S| is ill posed (growth rate unbounded as
k -> infinity) where

    4 nu^2 - 4 nu + mu^2 (1 - nu/2)^2 > 0,     nu = I mu'(I) / mu(I).            (Barker 2015)

Derivation and its proviso (checked against :mod:`granflow.theory.dispersion`): for a
perturbation exp(i k e.x + lambda t) of simple shear, with s = sin(2 theta) the projection of the
unit shear deviator on the direction e = (cos theta, sin theta) and b = mu (1 - nu/2), the single
leading-order eigenvalue is

    lambda / k^2 = (eta / (2 phi rho_s)) g(s) / (b s - 1),   g(s) = (1 - nu) s^2 - b s + nu,

eta = mu p / |S|. For b < 1 the denominator is negative, so the flow is ill posed iff
min over s in [-1, 1] of g(s) < 0. Barker's expression is -4(1 - nu) times the value of g at its
vertex s* = b / (2 (1 - nu)); it is exact only when that optimal direction exists (nu < 1 and
s* <= 1) and b < 1. :func:`barker_ill_posed` is the exact test; for the mu(I) law with mu2 < 1
(nu < 1/2) the two agree, which :func:`barker_window` checks and reports.

Inertial-number convention: the criterion depends on I only through x = I / I0, so a window
computed with I0 applied to the closure's own I (material c_I) is reported in that I and in the
literature I (gamma_dot-based, c_I = 2): I_literature = (2 / c_I) I.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from scipy.optimize import brentq

from granflow.materials import InertialConvention
from granflow.rheology.functions import dmu_dI, mu_of_I

#: The scan for sign changes covers x = I/I0 in [10**SCAN_LOG10_MIN, 10**SCAN_LOG10_MAX]; the
#: criterion tends to mu1^2 > 0 as x -> 0 and to mu2^2 > 0 as x -> inf, so any window lies inside.
SCAN_LOG10_MIN = -10.0
SCAN_LOG10_MAX = 6.0
#: Points of the log-spaced bracket scan.
SCAN_POINTS = 4001
#: Relative tolerance of brentq on I.
ROOT_RTOL = 1e-14
#: If the criterion is still negative at an end of the scan (possible when mu1 << mu2), that end
#: is pushed out by this many decades, at most MAX_EXTENSIONS times (the limits mu1^2 and mu2^2
#: are positive, so a root always exists).
EXTENSION_DECADES = 10.0
MAX_EXTENSIONS = 25


def barker_nu(I, mu1: float, mu2: float, I0: float):
    """nu = I mu'(I) / mu(I) [-], the log-slope of the friction law (Barker 2015)."""
    I = np.asarray(I, dtype=float)
    return I * dmu_dI(I, mu1, mu2, I0) / mu_of_I(I, mu1, mu2, I0)


def barker_criterion(I, mu1: float, mu2: float, I0: float):
    """Barker et al. (2015) quantity 4 nu^2 - 4 nu + mu^2 (1 - nu/2)^2 [-].

    Positive: ill posed (per Barker's criterion); negative: well posed.

    Parameters
    ----------
    I : array_like
        Inertial number [-], in the convention in which I0 is given.
    mu1, mu2, I0 : float
        Parameters of mu(I) = mu1 + (mu2 - mu1)/(1 + I0/I) (paper eq. mu(I)).

    Examples
    --------
    >>> round(float(barker_criterion(0.0, 0.4, 0.6, 0.3)), 12)  # nu = 0: mu1^2
    0.16
    """
    nu = barker_nu(I, mu1, mu2, I0)
    mu = mu_of_I(I, mu1, mu2, I0)
    return 4.0 * nu**2 - 4.0 * nu + mu**2 * (1.0 - 0.5 * nu) ** 2


def barker_ill_posed(I, mu1: float, mu2: float, I0: float):
    """Exact ill-posedness test of incompressible mu(I): min over s in [-1, 1] of
    g(s) = (1 - nu) s^2 - b s + nu is negative, or b >= 1 (the leading-order eigenvalue has a pole
    at s = 1/b and is unbounded). Returns a boolean array.

    Equals ``barker_criterion(I, ...) > 0`` wherever the optimal direction exists (see module
    docstring).
    """
    nu = barker_nu(I, mu1, mu2, I0)
    b = mu_of_I(I, mu1, mu2, I0) * (1.0 - 0.5 * nu)
    s_grid = (-1.0, 1.0)
    g_ends = np.minimum(*[(1.0 - nu) * s**2 - b * s + nu for s in s_grid])
    with np.errstate(divide="ignore", invalid="ignore"):
        s_star = b / (2.0 * (1.0 - nu))
        g_vertex = nu - b**2 / (4.0 * (1.0 - nu))
    interior = (nu < 1.0) & (np.abs(s_star) <= 1.0)
    g_min = np.where(interior, np.minimum(g_vertex, g_ends), g_ends)
    return (b >= 1.0) | (g_min < 0.0)


@dataclass(frozen=True)
class WellPosedWindow:
    """The range of I where incompressible mu(I) is well posed (Barker et al. 2015).

    Attributes
    ----------
    mu1, mu2, I0 : float
        mu(I) parameters; I0 applies to the I of the convention ``c_I``.
    c_I : float
        Inertial-number convention factor of ``I_low``, ``I_high`` (2: literature, 1: paper).
    I_low, I_high : float or None
        Window ends in that convention [-]; None if no window exists (or, for an end only, if
        the criterion is still negative after extending the scan, which needs mu1/mu2 or
        1/mu2 below about 1e-250).
    I_low_literature, I_high_literature : float or None
        The same physical window in the literature's I = d gamma_dot / sqrt(p/rho_s),
        i.e. (2 / c_I) times the above.
    exact : bool
        True if Barker's criterion equals the exact direction-optimised test
        (:func:`barker_ill_posed`) at every point of the scan.
    convention : str
        Human-readable statement of the convention.
    """

    mu1: float
    mu2: float
    I0: float
    c_I: float
    I_low: float | None
    I_high: float | None
    I_low_literature: float | None
    I_high_literature: float | None
    exact: bool
    convention: str

    @property
    def exists(self) -> bool:
        """True if a well-posed interval of I exists."""
        return self.I_low is not None or self.I_high is not None

    def to_dict(self) -> dict:
        """JSON-ready dictionary (floats, None, bool, str)."""
        out = asdict(self)
        out["exists"] = self.exists
        return out


def _convention_text(c_I: float) -> str:
    if c_I == float(InertialConvention.LITERATURE):
        name = "literature I = d gamma_dot / sqrt(p/rho_s)"
    elif c_I == float(InertialConvention.PAPER):
        name = "paper I = d |S| / sqrt(p/rho_s)"
    else:
        name = f"I = {c_I:g} d |S| / sqrt(p/rho_s)"
    return (
        f"I_low/I_high in the closure's I (c_I = {c_I:g}: {name}), with I0 applied to that I; "
        "*_literature: the same window in the literature I = (2/c_I) I"
    )


def barker_window(mu1: float, mu2: float, I0: float, c_I: float = float(InertialConvention.LITERATURE)) -> WellPosedWindow:
    """Well-posed window I_low < I < I_high of incompressible mu(I) (Barker et al. 2015).

    The roots of :func:`barker_criterion` are bracketed by a log-spaced scan of I/I0 and refined
    with brentq.

    Parameters
    ----------
    mu1, mu2, I0 : float
        mu(I) parameters [-]; I0 is in the convention ``c_I``.
    c_I : float
        Convention factor of the I in which I0 is given and the window is returned (2: literature,
        default; 1: the paper literally).

    Returns
    -------
    WellPosedWindow
        With None ends if the criterion is positive everywhere. If the criterion had several
        negative intervals (not the case for mu(I)), the hull of all of them is returned and
        ``exact`` is False.

    Examples
    --------
    >>> w = barker_window(0.4, 0.6, 0.3)
    >>> w.exists and w.I_low < 0.3 < w.I_high
    True
    """
    mu1, mu2, I0, c_I = float(mu1), float(mu2), float(I0), float(c_I)
    lo, hi = SCAN_LOG10_MIN, SCAN_LOG10_MAX
    for _ in range(MAX_EXTENSIONS):
        if barker_criterion(10.0**lo * I0, mu1, mu2, I0) >= 0:
            break
        lo -= EXTENSION_DECADES
    for _ in range(MAX_EXTENSIONS):
        if barker_criterion(10.0**hi * I0, mu1, mu2, I0) >= 0:
            break
        hi += EXTENSION_DECADES
    x = np.logspace(lo, hi, SCAN_POINTS) * I0
    crit = barker_criterion(x, mu1, mu2, I0)
    exact = bool(np.all((crit > 0) == barker_ill_posed(x, mu1, mu2, I0)))
    neg = crit < 0
    lit = float(InertialConvention.LITERATURE) / c_I
    if not np.any(neg):
        return WellPosedWindow(mu1, mu2, I0, c_I, None, None, None, None, exact, _convention_text(c_I))
    changes = np.flatnonzero(np.diff(neg.astype(int)) != 0)

    def root(i: int) -> float:
        return float(brentq(barker_criterion, x[i], x[i + 1], args=(mu1, mu2, I0), rtol=ROOT_RTOL))

    roots = [root(i) for i in changes]
    n_intervals = int(np.sum(np.diff(neg.astype(int)) == 1)) + int(neg[0])
    if n_intervals > 1:
        exact = False
    I_low = roots[0] if not neg[0] else None
    I_high = roots[-1] if not neg[-1] else None
    return WellPosedWindow(
        mu1, mu2, I0, c_I,
        I_low, I_high,
        None if I_low is None else lit * I_low,
        None if I_high is None else lit * I_high,
        exact, _convention_text(c_I),
    )
