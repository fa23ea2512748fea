"""The base state of the linear stability analysis (:mod:`granflow.theory.dispersion`): uniform
simple shear u0 = (gamma_dot z, 0), |S0| = gamma_dot/2 = I sqrt(p0/rho_s)/(c_I d) (paper eq. def:I),
and the closure's coefficients frozen there, plus the generalised-eigenvalue helper shared by the
leading-order and finite-k problems. Split from :mod:`granflow.theory.dispersion`, which
re-exports every name here; its docstring states the assumptions.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

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
    S = float(I * m.shear_rate_scale(p))  # |S0| = I sqrt(p/rho_s)/(c_I d)
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
