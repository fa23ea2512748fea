"""Leading-order (k -> infinity) linear stability of uniform simple shear (MODEL.md §8): with
lambda = Lambda k^2 and p_hat = i k P, a generalised eigenproblem in (u_hat, P[, Pf]) that also
covers the incompressible limit Gamma = 0; Lambda > 0 in some direction is ill posed (Barker et al.
2015, J. Fluid Mech. 779, 794; paper Theorem th3). Split from :mod:`granflow.theory.dispersion`,
which re-exports every name here; its docstring states the assumptions. Units: Lambda in m^2/s,
theta in rad.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar

from granflow.gas import GasLaw
from granflow.rheology.base import Closure
from granflow.theory.base_state import (
    DIM,
    SHEAR_DIRECTION,
    BaseState,
    _direction,
    _finite_eigenvalues,
    base_state,
)

#: Default number of directions theta in [0, pi) for the maxima over theta.
DEFAULT_THETA_POINTS = 360
#: Tolerance (in theta, rad) of the bounded refinement of the maximum over theta.
THETA_XTOL = 1e-10


# ---- leading order (k -> infinity), MODEL.md §8 ------------------------------------------------
def _viscous_block(state: BaseState, m: np.ndarray) -> np.ndarray:
    """-(eta/2)(Id - (1 - nu_Z) m m^T) - (eta_visc/2) Id [Pa s], written with eta nu_Z =
    I dZ_dI p/|S| so that it stays finite where Z = 0."""
    eta_nu = state.I * state.dZ_dI * state.p / state.S
    mm = np.outer(m, m)
    Id = np.eye(DIM)
    return -0.5 * state.eta * (Id - mm) - 0.5 * eta_nu * mm - 0.5 * state.eta_visc * Id


def leading_order_pencil(state: BaseState, theta: float, gas: str = GasLaw.LINEAR) -> tuple[np.ndarray, np.ndarray]:
    """Leading-order pencil (A, B), Lambda B x = A x, x = (u_hat (2), P/eta_s[, Pf/eta_s]).

    With lambda = Lambda k^2, p_hat = i k P, pf_hat = i k Pf (MODEL.md §8):

        Lambda phi rho_s u = -(eta/2)(Id - (1 - nu_Z) m m^T) u - (eta_visc/2) u - (b_Z m - e) P + e Pf
        0                  = (a_f m - e)^T u - Gamma P
        Lambda (1 - phi) Pf = -kappa_eff Pf                      (gas, absent for gas = "none")

    m = n e. P and Pf are scaled by eta_s = p/|S| + eta_visc to balance the matrix. Units of
    Lambda: m^2/s.
    """
    gas = GasLaw(gas)
    e = _direction(theta)
    m = SHEAR_DIRECTION @ e
    eta_s = state.eta_scale
    u, P, Pf = slice(0, DIM), DIM, DIM + 1
    size = DIM + 1 if gas is GasLaw.NONE else DIM + 2
    A = np.zeros((size, size))
    B = np.zeros((size, size))
    A[u, u] = _viscous_block(state, m)
    A[u, P] = -(state.b_Z * m - e) * eta_s
    A[P, u] = state.a_f * m - e
    A[P, P] = -state.Gamma * eta_s
    B[u, u] = state.phi * state.rho_s * np.eye(DIM)
    if gas is not GasLaw.NONE:
        A[u, Pf] = e * eta_s
        A[Pf, Pf] = -state.kappa_eff * eta_s
        B[Pf, Pf] = (1.0 - state.phi) * eta_s
    return A, B


def leading_order_matrix(state: BaseState, theta: float) -> tuple[np.ndarray, np.ndarray]:
    """The two terms of M (MODEL.md §8) for Gamma != 0: lambda phi rho_s u = k^2 (M1 + M2) u.

    Returns
    -------
    M1 : ndarray (2, 2)
        -(eta/2)(Id - (1 - nu_Z) m m^T) - (eta_visc/2) Id [Pa s].
    M2 : ndarray (2, 2)
        (1/Gamma)(e - b_Z m)(a_f m - e)^T [Pa s]; symmetric negative semi-definite iff C1
        (b_Z = a_f) and C3 (Gamma > 0).
    """
    e = _direction(theta)
    m = SHEAR_DIRECTION @ e
    M1 = _viscous_block(state, m)
    M2 = np.outer(e - state.b_Z * m, state.a_f * m - e) / state.Gamma
    return M1, M2


def leading_order_eigenvalues(
    closure: Closure, phi: float, p: float, I: float, theta: float, p_f: float = 0.0, gas: str = GasLaw.LINEAR
) -> np.ndarray:
    """Finite leading-order eigenvalues Lambda = lim lambda/k^2 [m^2/s] in direction theta.

    Two dry modes if Gamma != 0 (one if Gamma = 0: incompressible), plus the pore-pressure mode
    -kappa_eff/(1 - phi) unless gas = "none" (Theorem th3: the gas block is triangular).
    """
    state = base_state(closure, phi, p, I, p_f, gas)
    return _finite_eigenvalues(*leading_order_pencil(state, theta, gas))


def leading_order_growth(
    closure: Closure, phi: float, p: float, I: float, theta: float, p_f: float = 0.0, gas: str = GasLaw.LINEAR
) -> float:
    """Largest real part of the finite leading-order eigenvalues, Lambda [m^2/s].

    > 0 in some direction: growth ~ Lambda k^2 unbounded as k -> infinity (ill posed).

    Examples
    --------
    >>> from granflow.rheology import make_closure
    >>> c = make_closure("mu_i")
    >>> leading_order_growth(c, float(c.equilibrium.phi_eq(0.01)), 1e3, 0.01, 0.3) < 0
    True
    """
    return float(np.max(leading_order_eigenvalues(closure, phi, p, I, theta, p_f, gas).real))


@dataclass(frozen=True)
class LeadingOrderGrowth:
    """Maximum over directions of the leading-order growth coefficient.

    Attributes
    ----------
    growth : float
        max over theta of Lambda [m^2/s] (lambda ~ growth k^2).
    theta : float
        Direction [rad] in [0, pi) where it is attained (e = (cos theta, sin theta)).
    scale : float
        eta/(phi rho_s) [m^2/s], the natural size of Lambda, to judge "zero".
    thetas, growths : tuple of float
        The scanned directions [rad] and Lambda there [m^2/s].
    gas : str
        Gas law used.
    """

    growth: float
    theta: float
    scale: float
    thetas: tuple[float, ...]
    growths: tuple[float, ...]
    gas: str

    @property
    def well_posed(self) -> bool:
        """True if growth <= 0 up to 1e-10 of ``scale``."""
        return self.growth <= 1e-10 * self.scale

    def to_dict(self) -> dict:
        """JSON-ready dictionary."""
        return {
            "growth": self.growth, "theta": self.theta, "theta_deg": float(np.degrees(self.theta)),
            "scale": self.scale, "relative_growth": self.growth / self.scale, "well_posed": self.well_posed,
            "gas": self.gas, "thetas": list(self.thetas), "growths": list(self.growths),
        }


def _maximise_over_theta(fun, thetas: np.ndarray) -> tuple[float, float, np.ndarray]:
    """Max of fun over [0, pi): grid scan, then bounded refinement around the best grid point."""
    values = np.array([fun(t) for t in thetas])
    i = int(np.argmax(values))
    h = np.pi / thetas.size
    res = minimize_scalar(lambda t: -fun(t), bounds=(thetas[i] - h, thetas[i] + h), method="bounded",
                          options={"xatol": THETA_XTOL})
    if -res.fun > values[i]:
        return float(-res.fun), float(np.mod(res.x, np.pi)), values
    return float(values[i]), float(thetas[i]), values


def leading_order_max_growth(
    closure: Closure, phi: float, p: float, I: float, p_f: float = 0.0, gas: str = GasLaw.LINEAR,
    n_theta: int = DEFAULT_THETA_POINTS,
) -> LeadingOrderGrowth:
    """Maximum over theta in [0, pi) of :func:`leading_order_growth` (theta and theta + pi are
    equivalent), by a scan of ``n_theta`` directions refined with a bounded 1-D search.

    Returns
    -------
    LeadingOrderGrowth
    """
    state = base_state(closure, phi, p, I, p_f, gas)
    thetas = np.linspace(0.0, np.pi, n_theta, endpoint=False)

    def fun(t):
        return float(np.max(_finite_eigenvalues(*leading_order_pencil(state, t, gas)).real))

    g, t, values = _maximise_over_theta(fun, thetas)
    scale = abs(state.eta) / (state.phi * state.rho_s) + state.eta_visc / (state.phi * state.rho_s)
    return LeadingOrderGrowth(g, t, scale, tuple(map(float, thetas)), tuple(map(float, values)), GasLaw(gas).value)
