"""The closure evaluated at the Picard iterate: the cell viscosity and the linearised dilatancy
row of :meth:`granflow.model.Model.coefficients` (module docstring of :mod:`granflow.model`,
step 2; NUMERICS.md §4 for the regularisation), as a mixin of :class:`granflow.model.Model`
(it reads the model's ``closure``, ``material``, ``eps``, ``delta_p``, ``ambient`` and surface).
"""
from __future__ import annotations

import numpy as np

from granflow.model_options import VISCOUS_ADDITION_FACTOR, Coefficients
from granflow.physics import momentum as mom
from granflow.physics.dilatancy import ap_factor


class ClosureCoefficients:
    """Closure evaluation of :class:`granflow.model.Model` (a mixin; not used alone)."""

    @property
    def background_viscosity(self) -> float:
        """Viscosity added to every dense cell [Pa s]: ``ambient.eta_b`` if given, else
        ``ambient.eta_a`` with the threshold surface (v1: one number for both) and 0 with the
        indicator surface, whose material cells are grains only (the ambient neither drives nor
        drags the material). Measured on the fluidised chute (25 deg, beta = 0.15, 40 cells over
        h, from rest): eta_b = 1e-3 Pa s puts u_s 2.8 % under Bagnold's (a stress eta_b du/dz the
        yield stress does not carry, amplified ~9x by the flat mu(I)), 1e-5 Pa s 1.05 %,
        1e-6 Pa s 1.03 % (validation/inclined_plane/README.md)."""
        if self.ambient.eta_b is not None:
            return self.ambient.eta_b
        return 0.0 if self.indicator else self.ambient.eta_a

    def _viscosity(self, phi_e, p_k, S):
        """``(p_e, I_e, Z, eta)`` of :meth:`coefficients` on the given cells (no background)."""
        p_e = np.hypot(np.maximum(p_k, 0.0), self.delta_p)
        I_e = self.material.inertial_number(np.sqrt(S * S + self.eps * self.eps), p_e)
        with np.errstate(all="ignore"):
            Z = self.closure.Z(phi_e, I_e)
            eta = mom.yield_viscosity(Z, p_k, S, self.eps) + VISCOUS_ADDITION_FACTOR * self.closure.eta_visc
        return p_e, I_e, Z, eta

    def cell_viscosity(self, phi_e, p_k, S, cells) -> np.ndarray:
        """The viscosity of :meth:`coefficients` (its ``eta_c``) at the cells of the mask ``cells``
        only, ``eta_a`` elsewhere [Pa s]; no dilatancy row (the base friction's second evaluation,
        :func:`granflow.step.base_node_viscosity`)."""
        cells = np.asarray(cells, dtype=bool)
        idx = np.flatnonzero(cells)
        eta = self._viscosity(*(np.asarray(x, dtype=float)[idx] for x in (phi_e, p_k, S)))[3]
        out = np.full(cells.size, self.ambient.eta_a)
        out[idx] = eta + self.background_viscosity
        return out

    def coefficients(self, phi_e, p_k, S, dt: float, dense, tangent: bool = True) -> Coefficients:
        """Viscosity and linearised dilatancy row at the iterate (module docstring, step 2); the
        compaction term ``G sqrt(p)`` linearised by its tangent at ``p_k`` (``tangent``, a step's
        first sweep) or its secant ``G p / sqrt(p_e)`` (the later sweeps).

        The closure is evaluated at ``I_e = I(sqrt(|S|^2 + eps^2), p_e)``,
        ``p_e = sqrt(max(p_k, 0)^2 + delta_p^2)``: the
        inertial number of the regularised strain rate, finite and > 0 everywhere. Only the
        dense cells are evaluated: the ambient gets ``eta_a`` and ``b = C = 0`` (no row).
        """
        c = self.closure
        dense = np.asarray(dense, dtype=bool)
        idx = np.flatnonzero(dense)
        phi_e, p_k, S = (np.asarray(x, dtype=float)[idx] for x in (phi_e, p_k, S))
        p_e, I_e, Z, eta = self._viscosity(phi_e, p_k, S)
        with np.errstate(all="ignore"):
            shear = np.where(S > 0, 2.0 * S * c.A(phi_e, I_e), 0.0)
            dshear = np.maximum(np.where(S > 0, S * I_e * c.dA_dI(phi_e, I_e), 0.0), 0.0)
            fac = ap_factor(c, phi_e, p_e, S, dt)
            live = fac > 0  # fac = 0: infinitely stiff relaxation, the constraint is div u = 0
            # tangent: b - C p is the law's Newton linearisation in p about p_k, the compaction
            # term -G sqrt(p) included; else its secant G p/sqrt(p_e) (twice as stiff). A step's
            # first sweep takes the tangent: one sweep (and so every step whose change lies below
            # picard.tol, or one solve per step) then solves the row of p^{n+1} to first order,
            # where the secant left a lag -G/(2 sqrt p) (p^{n+1} - p^n) that grew a period-2 mode
            # of the fluidised chute for dt >= 0.045 s; later sweeps the secant, whose loop
            # converged in more steps of the flagship (docs/solver.md, "One solve per step")
            half_G = 0.5 * c.compaction_coefficient(phi_e) / np.sqrt(p_e)
            if tangent:
                b = np.where(live, fac * (shear + dshear - half_G * np.maximum(p_k, 0.0)), 0.0)
                C = np.where(live, fac * (half_G + dshear / p_e), 0.0)
            else:
                b = np.where(live, fac * (shear + dshear), 0.0)
                C = np.where(live, fac * (2 * half_G + dshear / p_e), 0.0)
        bad = {name: int(np.count_nonzero(~np.isfinite(v))) for name, v in (("Z", Z), ("b", b), ("C", C))}
        n = dense.size
        eta_c = np.full(n, self.ambient.eta_a)
        eta_c[idx] = eta + self.background_viscosity
        b_c, C_c = np.zeros(n), np.zeros(n)
        b_c[idx], C_c[idx] = b, C
        return Coefficients(eta_c=eta_c, b=b_c, C=C_c, n_negative_Z=int(np.count_nonzero(Z < 0)),
                            nonfinite={k: v for k, v in bad.items() if v})
