"""Linear stability of the model about uniform simple shear with frozen coefficients.

Model: paper eqs syst1b-syst4b (MODEL.md §2), linearised about the uniform state

    u0 = (gamma_dot z, 0) in the x-z plane,  S0 = |S0| n,  n = [[0, 1], [1, 0]]  (n:n/2 = 1),
    |S0| = gamma_dot / 2 = I sqrt(p0/rho_s) / (c_I d),   phi0, p0, p_f0 uniform,

with perturbations ~ exp(i k e.x + lambda t), e = (cos theta, sin theta); k in 1/m, lambda in 1/s.

Assumptions (stated once, valid for every function below):

* gravity is ignored (it does not enter the linearised operator about a uniform state);
* coefficients are frozen at the base state; the state is a steady solution only if
  f(phi0, p0, I) = 0 (phi0 = phi_eq(I)), otherwise its own dilatation is ignored;
* the Doppler shift i k e.u0(x) is dropped (frame moving with the base flow at the point), so
  the advection of the perturbation by the base flow enters only through (u_hat . grad) u0;
* ``gas`` selects the pore-gas equation: ``"linear"`` (paper eq. syst2b), ``"nonlinear"``
  (right-hand side div(kappa (p_atm + p_f) grad p_f), eq. pressure-diffusion-nonlinear) or
  ``"none"`` (dry model, p_f = 0: the matrix N of the proof of Theorem th3).

The base state is :mod:`granflow.theory.base_state`, the leading order
:mod:`granflow.theory.leading_order` (both re-exported here). Two computations are provided and
cross-checked by the tests:

* :func:`dispersion_eigenvalues` — the full linear system at finite k (unknowns phi_hat, u_hat,
  w_hat, p_hat, pf_hat) solved as a generalised eigenproblem lambda B x = A x;
* :func:`leading_order_eigenvalues` — the k -> infinity limit of MODEL.md §8, lambda = Lambda k^2
  with p_hat = i k P, a generalised eigenproblem in (u_hat, P[, Pf]) that also covers the
  incompressible limit Gamma = 0.

The finite-k spectrum contains, besides the O(k^2) modes of the leading-order problem, an O(1)
compaction mode (phi_hat = O(1), u_hat = O(1/k)); lambda = 0 for the incompressible closure, whose
phi is passively advected. So the finite-k max growth rate / k^2 tends to max(Lambda_max, 0) and
the comparison with the leading order is made mode by mode. What the tests establish about it:

* with C1-C3 and dZ_dI > 0 (mu_i, power_law, dilatancy closures) its k -> infinity limit is
  bounded (well posed) but may be positive: of order 2|S| phi0 df_dphi, 1e2-2e4 1/s at
  I = 1e-2, p = 1 kPa, far above gamma_dot — uniform shear is linearly unstable, not ill posed;
* for plain Drucker-Prager (dZ_dI = 0, leading order only marginal) it tends to
  2|S| phi0 df_dphi s/(sin(delta) - s), s = sin(2 theta), unbounded as s -> sin(delta) from
  below; together with Lambda ~ -(s - sin(delta))^2 the max over theta grows like k^(2/3), so the
  relaxed condition C2 (Z + I dZ_dI >= 0) is not sufficient; eta_visc > 0 bounds it.

Growth rates below about gamma_dot are not meaningful here: with frozen coefficients and no Doppler
term the wave vector is not tilted by the base shear, so (u_hat . grad) u0 gives spurious O(|S0|)
growth at small k.

The sign convention is lambda > 0 = growth (the paper's proof of th3 uses the opposite sign, and
its printed eq. pressure-linear, dt p_f = -c Delta p_f, has the wrong sign: it is +c Delta; the gas mode is
lambda = -c k^2, c = p_atm kappa(phi0)/(1 - phi0)).
"""
from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

import numpy as np

from granflow.errors import GranflowInputError
from granflow.gas import GasLaw
from granflow.rheology.base import Closure
from granflow.theory.base_state import (  # noqa: F401  (re-exported)
    DIM,
    INFINITE_EIGENVALUE_FACTOR,
    SHEAR_DIRECTION,
    BaseState,
    _direction,
    _finite_eigenvalues,
    base_state,
)
from granflow.theory.leading_order import (  # noqa: F401  (re-exported)
    DEFAULT_THETA_POINTS,
    THETA_XTOL,
    LeadingOrderGrowth,
    _maximise_over_theta,
    leading_order_eigenvalues,
    leading_order_growth,
    leading_order_matrix,
    leading_order_max_growth,
    leading_order_pencil,
)

#: Default k range [1/m] of :func:`most_unstable`: 10**K_LOG10_MIN up to 2 pi / d.
K_LOG10_MIN = 0.0
DEFAULT_K_POINTS = 61


# ---- finite k: the full linearised system -----------------------------------------------------
class Unknown(IntEnum):
    """Position of each unknown in the finite-k vector x (PF absent for the dry model)."""

    PHI = 0
    U = 1
    W = 2
    P = 3
    PF = 4


def _n_unknowns(gas: GasLaw) -> int:
    return len(Unknown) - 1 if gas is GasLaw.NONE else len(Unknown)


def _linear_operator(state: BaseState, k: float, theta: float, gas: GasLaw, x: np.ndarray) -> np.ndarray:
    """A x: right-hand sides of the linearised eqs syst1b, syst3b, syst4b, syst2b for the
    perturbation x = (phi_hat, u_hat, w_hat, p_hat[, pf_hat]).

    Rows: mass (lambda phi_hat = ...), momentum x, z (lambda phi rho_s u_hat = ...), dilatancy
    constraint (0 = ...), gas (lambda [(1 - phi) pf_hat - p_f phi_hat] = ...).
    """
    e = _direction(theta)
    n = SHEAR_DIRECTION
    ik = 1j * k
    phi_h, u_h, p_h = x[Unknown.PHI], x[Unknown.U:Unknown.W + 1], x[Unknown.P]
    pf_h = x[Unknown.PF] if gas is not GasLaw.NONE else 0.0
    div_h = ik * (e @ u_h)
    grad_u = ik * np.outer(u_h, e)                                  # (grad u)_ij = d_j u_i
    S_h = 0.5 * (grad_u + grad_u.T) - 0.5 * div_h * np.eye(DIM)     # eq. def:S, perturbed
    dS_h = 0.5 * np.sum(n * S_h)                                    # delta|S| = S0:S_hat/(2|S0|)
    I_h = state.I * (dS_h / state.S - p_h / (2.0 * state.p))        # eq. def:I, perturbed
    dn_h = (S_h - n * dS_h) / state.S                               # delta(S/|S|)
    tau_h = (state.p * n * (state.dZ_dphi * phi_h + state.dZ_dI * I_h) + state.Z * n * p_h
             + state.Z * state.p * dn_h + state.eta_visc * S_h)
    base_grad = state.gamma_dot * np.array([[0.0, 1.0], [0.0, 0.0]])  # grad u0 for u0 = (gamma_dot z, 0)
    mass = -state.phi * div_h
    momentum = (-ik * e * p_h - ik * e * pf_h + ik * (tau_h @ e)
                - state.phi * state.rho_s * (base_grad @ u_h))
    constraint = 2.0 * dS_h * state.f + 2.0 * state.S * (
        state.df_dphi * phi_h + state.df_dp * p_h + state.df_dI * I_h) - div_h
    rows = [mass, momentum[0], momentum[1], constraint]
    if gas is not GasLaw.NONE:
        rows.append(-((1.0 - state.phi) * state.p_f + state.p_atm) * div_h - state.kappa_eff * k**2 * pf_h)
    return np.array(rows, dtype=complex)


def dispersion_pencil(state: BaseState, k: float, theta: float, gas: str = GasLaw.LINEAR) -> tuple[np.ndarray, np.ndarray]:
    """Finite-k pencil (A, B) of lambda B x = A x, balanced by diagonal scalings.

    Unknowns are scaled by (phi k/lambda_s, 1, 1, eta_s k, eta_s k) and equations by
    (1/(phi k), 1/(eta_s k^2), 1/(eta_s k^2), 1/k, 1/((1 - phi) eta_s k lambda_s)), with
    eta_s = p/|S| + eta_visc and lambda_s = eta_s k^2/(phi rho_s): this leaves the eigenvalues
    unchanged, makes every diagonal entry of B equal to 1/lambda_s and the O(k^2) entries of A
    O(1), so that QZ resolves the O(1) compaction mode next to the O(k^2) ones.
    """
    gas = GasLaw(gas)
    size = _n_unknowns(gas)
    A = np.column_stack([_linear_operator(state, k, theta, gas, col) for col in np.eye(size, dtype=complex)])
    B = np.zeros((size, size), dtype=complex)
    B[Unknown.PHI, Unknown.PHI] = 1.0
    B[Unknown.U, Unknown.U] = B[Unknown.W, Unknown.W] = state.phi * state.rho_s
    if gas is not GasLaw.NONE:
        B[Unknown.PF, Unknown.PF] = 1.0 - state.phi
        B[Unknown.PF, Unknown.PHI] = -state.p_f
    eta_s = state.eta_scale
    lam_s = eta_s * k**2 / (state.phi * state.rho_s)
    cols = np.array([state.phi * k / lam_s, 1.0, 1.0, eta_s * k, eta_s * k])[:size]
    rows = np.array([1.0 / (state.phi * k), 1.0 / (eta_s * k**2), 1.0 / (eta_s * k**2), 1.0 / k,
                     1.0 / ((1.0 - state.phi) * eta_s * k * lam_s)])[:size]
    return rows[:, None] * A * cols[None, :], rows[:, None] * B * cols[None, :]


def dispersion_eigenvalues(
    closure: Closure, phi: float, p: float, I: float, k: float, theta: float, p_f: float = 0.0,
    gas: str = GasLaw.LINEAR,
) -> np.ndarray:
    """Finite eigenvalues lambda [1/s] of the full linearised model at wavenumber k [1/m] in
    direction theta [rad] (complex array, unsorted).

    Examples
    --------
    >>> from granflow.rheology import make_closure
    >>> c = make_closure("drucker_prager")
    >>> lam = dispersion_eigenvalues(c, 0.598, 1e3, 0.01, 1e3, 0.5)
    >>> lam.size   # phi, u, w, p_f modes (the constraint row removes one)
    4
    """
    if not k > 0:
        raise GranflowInputError(f"k = {k} 1/m must be positive")
    state = base_state(closure, phi, p, I, p_f, gas)
    return _finite_eigenvalues(*dispersion_pencil(state, k, theta, gas))


def growth_rate(
    closure: Closure, phi: float, p: float, I: float, k: float, theta: float, p_f: float = 0.0,
    gas: str = GasLaw.LINEAR,
) -> float:
    """Largest real part of :func:`dispersion_eigenvalues` [1/s]."""
    return float(np.max(dispersion_eigenvalues(closure, phi, p, I, k, theta, p_f, gas).real))


@dataclass(frozen=True)
class GrowthCurve:
    """Growth rate on a (theta, k) grid.

    Attributes
    ----------
    k : tuple of float
        Wavenumbers [1/m].
    theta : tuple of float
        Directions [rad].
    growth : tuple of tuple of float
        growth[i][j] = max Re lambda at (theta[i], k[j]) [1/s].
    """

    k: tuple[float, ...]
    theta: tuple[float, ...]
    growth: tuple[tuple[float, ...], ...]

    def as_array(self) -> np.ndarray:
        """growth as an array of shape (n_theta, n_k) [1/s]."""
        return np.array(self.growth)

    def to_dict(self) -> dict:
        """JSON-ready dictionary."""
        return {"k": list(self.k), "theta": list(self.theta), "growth": [list(r) for r in self.growth],
                "units": {"k": "1/m", "theta": "rad", "growth": "1/s"}}


def growth_curve(
    closure: Closure, phi: float, p: float, I: float, k_values, thetas, p_f: float = 0.0,
    gas: str = GasLaw.LINEAR,
) -> GrowthCurve:
    """:func:`growth_rate` on the grid thetas x k_values (for plotting)."""
    k_values = np.atleast_1d(np.asarray(k_values, dtype=float))
    thetas = np.atleast_1d(np.asarray(thetas, dtype=float))
    if np.any(k_values <= 0):
        raise GranflowInputError("k_values must be positive [1/m]")
    state = base_state(closure, phi, p, I, p_f, gas)
    growth = [[float(np.max(_finite_eigenvalues(*dispersion_pencil(state, k, t, gas)).real)) for k in k_values]
              for t in thetas]
    return GrowthCurve(tuple(map(float, k_values)), tuple(map(float, thetas)), tuple(map(tuple, growth)))


@dataclass(frozen=True)
class MostUnstable:
    """Maximum growth over a (theta, k) grid.

    Attributes
    ----------
    growth : float
        max Re lambda [1/s].
    theta : float
        Direction [rad].
    k : float
        Wavenumber [1/m].
    at_largest_k : bool
        True if the maximum sits at the largest k of the grid (growth possibly unbounded).
    """

    growth: float
    theta: float
    k: float
    at_largest_k: bool

    def to_dict(self) -> dict:
        """JSON-ready dictionary."""
        return {"growth": self.growth, "theta": self.theta, "theta_deg": float(np.degrees(self.theta)),
                "k": self.k, "at_largest_k": self.at_largest_k, "units": {"growth": "1/s", "k": "1/m"}}


def most_unstable(
    closure: Closure, phi: float, p: float, I: float, k_values=None, thetas=None, p_f: float = 0.0,
    gas: str = GasLaw.LINEAR,
) -> MostUnstable:
    """Maximum of :func:`growth_rate` over a grid of k and theta.

    Parameters
    ----------
    k_values : array_like, optional
        Wavenumbers [1/m]; default ``DEFAULT_K_POINTS`` log-spaced from 1 to 2 pi/d.
    thetas : array_like, optional
        Directions [rad]; default ``DEFAULT_THETA_POINTS`` in [0, pi).
    """
    if k_values is None:
        k_values = np.logspace(K_LOG10_MIN, np.log10(2.0 * np.pi / closure.material.d), DEFAULT_K_POINTS)
    if thetas is None:
        thetas = np.linspace(0.0, np.pi, DEFAULT_THETA_POINTS, endpoint=False)
    curve = growth_curve(closure, phi, p, I, k_values, thetas, p_f, gas)
    g = curve.as_array()
    i, j = np.unravel_index(int(np.argmax(g)), g.shape)
    return MostUnstable(float(g[i, j]), curve.theta[i], curve.k[j], bool(j == len(curve.k) - 1))
