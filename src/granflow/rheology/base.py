"""The closure interface: a pair (Z, f) of the paper, eqs ``def:tau`` and ``def:div``.

    tau    = Z(phi, I) p S/|S|            (+ eta_visc S, optional viscous addition, Remarks
                                            rem-viscous1-3)
    div u  = 2 |S| f(phi, p, I)

Every closure of granflow writes its dilatancy function in the form

    f(phi, p, I) = A(phi, I) - B(phi) / I                                          (*)

(eq. f-general: A = W(phi, I), B = I_eq W(phi, I_eq)), which is what makes the divergence law
stiff-safe: with I = c_I d |S| / sqrt(p/rho_s),

    div u = 2 |S| A(phi, I) - 2 B(phi) sqrt(p) / (c_I d sqrt(rho_s)),

finite as |S| -> 0 (MODEL.md §6.6). Closures implement A, B and their derivatives; the base class
derives f, its derivatives, the divergence law and the dissipation density from them.

Units: phi, I, Z, f are dimensionless; p in Pa; |S| in s^-1; div u in s^-1.
"""
from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from pydantic import Field, model_validator

from granflow.equilibrium import EQUILIBRIUM_LAWS, EquilibriumLaw, LinearEquilibrium
from granflow.errors import GranflowInputError
from granflow.materials import Material
from granflow.params import Params, build
from granflow.registry import Registry

ArrayLike = Any


def _arr(x) -> np.ndarray:
    return np.asarray(x, dtype=float)


class Closure(Params):
    """Base class of the (Z, f) closures.

    Attributes
    ----------
    material : Material
        Grain, gas and packing parameters (d, rho_s, c_I, ...).
    equilibrium : EquilibriumLaw
        The law I_eq(phi) fixing the integration constant of f (Theorem th2). Its ``phi_max``
        must equal ``material.phi_max``.
    eta_visc : float
        Optional viscous addition eta_visc S to the stress [Pa s] (Remarks rem-viscous1-3: it keeps
        every property and adds the dissipation 2 eta_visc |S|^2). Default 0.
    """

    name: ClassVar[str]
    summary: ClassVar[str] = ""
    #: True for the closures kept only for comparison (Roux-Radjai, incompressible).
    reference: ClassVar[bool] = False
    #: Paper label(s) of the equations the closure implements.
    source: ClassVar[str] = ""
    #: True when f = 0 (div u = 0): the equilibrium law phi_eq(I) plays no part in the flow.
    isochoric: ClassVar[bool] = False

    material: Material = Field(default_factory=Material)
    equilibrium: EquilibriumLaw = Field(default_factory=LinearEquilibrium)
    eta_visc: float = Field(0.0, ge=0, description="viscous addition to the stress [Pa s]")

    @model_validator(mode="after")
    def _consistent_phi_max(self):
        if abs(self.equilibrium.phi_max - self.material.phi_max) > 1e-15:
            raise ValueError(
                f"equilibrium.phi_max = {self.equilibrium.phi_max} differs from "
                f"material.phi_max = {self.material.phi_max}"
            )
        return self

    # ---- to be provided by each closure -------------------------------------------------------
    def Z(self, phi, I):
        """Yield function Z(phi, I) [-] (eq. def:tau)."""
        raise NotImplementedError

    def dZ_dI(self, phi, I):
        """Partial derivative of Z with respect to I at fixed phi [-]."""
        raise NotImplementedError

    def dZ_dphi(self, phi, I):
        """Partial derivative of Z with respect to phi at fixed I [-]."""
        raise NotImplementedError

    def A(self, phi, I):
        """Rate part A(phi, I) of f = A - B/I [-]."""
        raise NotImplementedError

    def dA_dI(self, phi, I):
        raise NotImplementedError

    def dA_dphi(self, phi, I):
        raise NotImplementedError

    def B(self, phi):
        """Compaction part B(phi) of f = A - B/I [-]; B = I_eq W(phi, I_eq) for eq. f-general."""
        return np.zeros_like(_arr(phi))

    def dB_dphi(self, phi):
        return np.zeros_like(_arr(phi))

    # ---- derived ------------------------------------------------------------------------------
    def I_eq(self, phi):
        """Equilibrium inertial number I_eq(phi) of the closure's equilibrium law [-]."""
        return self.equilibrium.I_eq(phi)

    def f(self, phi, p, I):
        """Dilatancy function f(phi, p, I) = A(phi, I) - B(phi)/I [-] (eq. def:div)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return self.A(phi, I) - self.B(phi) / _arr(I)

    def df_dI(self, phi, p, I):
        """Partial derivative of f with respect to I at fixed (phi, p) [-]."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return self.dA_dI(phi, I) + self.B(phi) / _arr(I) ** 2

    def df_dp(self, phi, p, I):
        """Partial derivative of f with respect to p at fixed (phi, I) [Pa^-1]; zero for every
        closure of the paper (f depends on p only through I)."""
        return np.zeros(np.broadcast(_arr(phi), _arr(p), _arr(I)).shape)

    def df_dphi(self, phi, p, I):
        """Partial derivative of f with respect to phi at fixed (p, I) [-]."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return self.dA_dphi(phi, I) - self.dB_dphi(phi) / _arr(I)

    def compaction_coefficient(self, phi):
        """G(phi) = 2 B(phi) / (c_I d sqrt(rho_s)) [Pa^-1/2 s^-1], so that the pressure part of the
        divergence law is -G sqrt(p) (:attr:`granflow.materials.Material.inertial_scale`). For
        Drucker-Prager G = 2 lambda sin(delta)(phi_max - phi)."""
        m = self.material
        return 2.0 * self.B(phi) / m.inertial_scale

    def div_rate(self, phi, p, S):
        """Divergence law div u = 2 |S| f(phi, p, I) in stiff-safe form [s^-1] (eq. syst4b).

        Evaluated as 2 |S| A(phi, I) - G(phi) sqrt(p), which is finite at |S| = 0 (where it is
        -G sqrt(p)) and at p = 0 (where I = inf).

        Parameters
        ----------
        phi : array_like
            Solid volume fraction [-].
        p : array_like
            Granular pressure [Pa], >= 0.
        S : array_like
            Deviatoric strain-rate norm |S| [s^-1].
        """
        phi, p, S = _arr(phi), _arr(p), _arr(S)
        I = self.material.inertial_number(S, p)
        with np.errstate(invalid="ignore", over="ignore"):
            shear = np.where(S <= 0, 0.0, 2.0 * S * self.A(phi, I))
            # 0 at p = 0 even where G = inf (I_eq = inf, e.g. Schaeffer's law below phi_max - delta_phi);
            # the "<= 0" tests let NaN propagate.
            compaction = np.where(p <= 0, 0.0, self.compaction_coefficient(phi) * np.sqrt(np.maximum(p, 0.0)))
        return shear - compaction

    def dissipation_density(self, phi, p, S):
        """Local dissipation rate 2 (Z - f) p |S| + 2 eta_visc |S|^2 [W m^-3] (eq.
        dissipation-general-exp), evaluated as 2 Z p |S| - p div u, finite at |S| = 0 and p = 0."""
        phi, p, S = _arr(phi), _arr(p), _arr(S)
        I = self.material.inertial_number(S, p)
        with np.errstate(invalid="ignore", over="ignore"):
            yield_part = np.where((S <= 0) | (p <= 0), 0.0, 2.0 * self.Z(phi, I) * p * S)
            dil = np.where(p <= 0, 0.0, p * self.div_rate(phi, p, S))
        return yield_part - dil + 2.0 * self.eta_visc * S**2

    def parameters(self) -> dict[str, Any]:
        """The closure's own parameters (without material and equilibrium), JSON-ready."""
        return self.model_dump(exclude={"material", "equilibrium"})

    def describe(self) -> dict[str, Any]:
        """Everything that defines the closure, JSON-ready."""
        return {
            "closure": self.name,
            "parameters": self.parameters(),
            "material": self.material.model_dump(),
            "equilibrium": {"law": self.equilibrium.name, **self.equilibrium.model_dump()},
        }


CLOSURES: Registry[Closure] = Registry("closure")


def make_equilibrium(name: str, material: Material, params: dict[str, Any] | None = None) -> EquilibriumLaw:
    """Build the equilibrium law ``name``, taking phi_max (and delta_phi, where the law has it)
    from ``material`` unless given in ``params``."""
    cls = EQUILIBRIUM_LAWS.get(name)
    p = dict(params or {})
    if "phi_max" in p and p["phi_max"] != material.phi_max:
        raise GranflowInputError(
            f"equilibrium.phi_max = {p['phi_max']} differs from material.phi_max = {material.phi_max}; "
            "set material.phi_max instead"
        )
    p["phi_max"] = material.phi_max
    if "delta_phi" in cls.model_fields and "delta_phi" not in p:
        p["delta_phi"] = material.delta_phi
    return build(cls, p, context="equilibrium")


def make_closure(
    name: str,
    material: Material | dict[str, Any] | None = None,
    equilibrium: str = "linear",
    equilibrium_params: dict[str, Any] | None = None,
    **params: Any,
) -> Closure:
    """Build a registered closure with validated parameters.

    Parameters
    ----------
    name : str
        Registry key (``granflow list closures``).
    material : Material or dict, optional
        Material parameters (defaults: glass beads in air, c_I = 2).
    equilibrium : str
        Equilibrium-law registry key (default ``"linear"``).
    equilibrium_params : dict, optional
        Extra parameters of the equilibrium law.
    **params
        The closure's own parameters (e.g. ``delta_deg=25``, ``mu1=0.38``).

    Examples
    --------
    >>> from granflow.rheology import make_closure
    >>> c = make_closure("drucker_prager", delta_deg=30.0)
    >>> float(c.f(0.5, 1000.0, c.I_eq(0.5)))
    0.0
    """
    cls = CLOSURES.get(name)
    if material is None:
        material = Material()
    elif isinstance(material, dict):
        material = build(Material, material, context="material")
    eq = make_equilibrium(equilibrium, material, equilibrium_params)
    return build(cls, {"material": material, "equilibrium": eq, **params}, context="closure")
