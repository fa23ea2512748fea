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

Two computations are provided and cross-checked by the tests:

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
import scipy.linalg
from scipy.optimize import minimize_scalar

from granflow.gas import GasLaw
from granflow.errors import GranflowInputError
from granflow.rheology.base import Closure

#: Space dimension (x-z plane).
DIM = 2
#: Unit deviator of simple shear u0 = (gamma_dot z, 0).
SHEAR_DIRECTION = np.array([[0.0, 1.0], [1.0, 0.0]])
#: A generalised eigenvalue alpha/beta is kept as finite if |lambda| <= this factor times the
#: natural scale ||A||/||B|| (Frobenius) of the (scaled) pencil; the eigenvalues that the singular
#: constraint row sends to infinity come out of QZ at about 1e16 times that scale.
INFINITE_EIGENVALUE_FACTOR = 1e8
#: Default number of directions theta in [0, pi) for the maxima over theta.
DEFAULT_THETA_POINTS = 360
#: Tolerance (in theta, rad) of the bounded refinement of the maximum over theta.
THETA_XTOL = 1e-10
#: Default k range [1/m] of :func:`most_unstable`: 10**K_LOG10_MIN up to 2 pi / d.
K_LOG10_MIN = 0.0
DEFAULT_K_POINTS = 61


@dataclass(frozen=True)
class BaseState:
    """Uniform simple-shear base state and the closure coefficients frozen at it.

    Attributes
    ----------
    phi, p, I, p_f : float
        Volume fraction [-], granular pressure [Pa], inertial number [-] (closure convention),
        gauge pore pressure [Pa].
    S : float
        |S0| = I sqrt(p/rho_s)/(c_I d) [1/s]; gamma_dot = 2 |S0|.
    Z, dZ_dI, dZ_dphi, f, df_dI, df_dp, df_dphi : float
        Closure values and partial derivatives at (phi, p, I) (df_dp in 1/Pa).
    eta : float
        Z p / |S0| [Pa s], the effective viscosity of the yield term.
    eta_visc : float
        Viscous addition [Pa s].
    rho_s : float
        Grain density [kg/m^3].
    kappa_eff : float
        Gas diffusion coefficient of the right-hand side: p_atm kappa (linear),
        (p_atm + p_f) kappa (nonlinear), 0 (dry) [m^2/s].
    p_atm : float
        Atmospheric pressure [Pa].
    """

    phi: float
    p: float
    I: float
    p_f: float
    S: float
    Z: float
    dZ_dI: float
    dZ_dphi: float
    f: float
    df_dI: float
    df_dp: float
    df_dphi: float
    eta: float
    eta_visc: float
    rho_s: float
    kappa_eff: float
    p_atm: float

    @property
    def gamma_dot(self) -> float:
        """Shear rate 2 |S0| [1/s]."""
        return 2.0 * self.S

    @property
    def nu_Z(self) -> float:
        """I dZ_dI / Z [-]."""
        return self.I * self.dZ_dI / self.Z

    @property
    def b_Z(self) -> float:
        """Z - (I/2) dZ_dI [-] (left-hand side of C1)."""
        return self.Z - 0.5 * self.I * self.dZ_dI

    @property
    def a_f(self) -> float:
        """f + I df_dI [-] (right-hand side of C1)."""
        return self.f + self.I * self.df_dI

    @property
    def Gamma(self) -> float:
        """-2 |S0| (df_dp - (I/(2p)) df_dI) [1/(Pa s)]; > 0 iff C3 holds."""
        return -2.0 * self.S * (self.df_dp - 0.5 * self.I / self.p * self.df_dI)

    @property
    def gas_rate(self) -> float:
        """c = kappa_eff / (1 - phi) [m^2/s]: the pore-pressure mode is lambda = -c k^2."""
        return self.kappa_eff / (1.0 - self.phi)

    @property
    def eta_scale(self) -> float:
        """p/|S0| + eta_visc [Pa s], the viscosity scale used to balance the matrices."""
        return self.p / self.S + self.eta_visc


def base_state(closure: Closure, phi: float, p: float, I: float, p_f: float = 0.0, gas: str = GasLaw.LINEAR) -> BaseState:
    """Evaluate the closure at the base state (phi, p, I) and freeze its coefficients.

    Parameters
    ----------
    closure : Closure
        Any registered closure (its ``material`` gives d, rho_s, c_I, kappa, p_atm).
    phi : float
        Solid volume fraction, 0 < phi < 1.
    p : float
        Granular pressure [Pa], > 0.
    I : float
        Inertial number [-] in the closure's convention, > 0.
    p_f : float
        Base gauge pore pressure [Pa], > -p_atm.
    gas : {"linear", "nonlinear", "none"}
        Pore-gas equation (see :class:`GasLaw`).
    """
    gas = GasLaw(gas)
    if not (0.0 < phi < 1.0 and p > 0.0 and I > 0.0):
        raise GranflowInputError(f"base state needs 0 < phi < 1, p > 0, I > 0; got phi={phi}, p={p}, I={I}")
    m = closure.material
    if not p_f > -m.p_atm:
        raise GranflowInputError(f"p_f = {p_f} Pa must exceed -p_atm = {-m.p_atm} Pa")
    S = float(I * np.sqrt(p / m.rho_s) / (m.c_I * m.d))
    Z = float(closure.Z(phi, I))
    kappa = float(m.permeability(phi))
    kappa_eff = {GasLaw.NONE: 0.0, GasLaw.LINEAR: m.p_atm * kappa, GasLaw.NONLINEAR: (m.p_atm + p_f) * kappa}[gas]
    return BaseState(
        phi=float(phi), p=float(p), I=float(I), p_f=float(p_f) if gas is not GasLaw.NONE else 0.0, S=S,
        Z=Z, dZ_dI=float(closure.dZ_dI(phi, I)), dZ_dphi=float(closure.dZ_dphi(phi, I)),
        f=float(closure.f(phi, p, I)), df_dI=float(closure.df_dI(phi, p, I)),
        df_dp=float(closure.df_dp(phi, p, I)), df_dphi=float(closure.df_dphi(phi, p, I)),
        eta=Z * p / S, eta_visc=float(closure.eta_visc), rho_s=float(m.rho_s),
        kappa_eff=float(kappa_eff), p_atm=float(m.p_atm),
    )


def _direction(theta: float) -> np.ndarray:
    return np.array([np.cos(theta), np.sin(theta)])


def _finite_eigenvalues(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Finite eigenvalues of lambda B x = A x (QZ), dropping infinite and NaN ones."""
    alpha, beta = scipy.linalg.eig(A, B, right=False, homogeneous_eigvals=True)
    scale = np.linalg.norm(A) / np.linalg.norm(B)
    finite = np.abs(alpha) <= INFINITE_EIGENVALUE_FACTOR * scale * np.abs(beta)
    finite &= np.isfinite(alpha) & np.isfinite(beta)
    return alpha[finite] / beta[finite]


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
