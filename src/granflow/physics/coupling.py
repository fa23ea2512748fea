"""Pore-gas pressure in the monolithic (u, p, p_f) step (paper eqs syst2b-syst3b; MODEL.md §2, §5;
NUMERICS.md §3.1, §3.3, §8, §9).

Gas rows, on the *wet* cells (the dense cells of ``phi^n``, free or active; ``p_f = 0`` in the
ambient), step n -> n+1::

    (1 - phi*) p_f^{n+1}/dt - div(K grad p_f^{n+1}) + p_atm Div u^{n+1}
        = (1 - phi^n) p_f^n/dt - T^n + s                                             [Pa s^-1]

* ``T^n = div((1 - phi^n) p_f^n u^n)``, explicit first-order upwind
  (:func:`granflow.physics.pore_pressure.transport_divergence`);
* ``phi*`` = the packing predicted by the phi transport with ``u^n``
  (:func:`granflow.physics.transport.advect`), clipped to ``[0, phi_max]``: capacity and kappa.
  The time difference is then that of ``(1 - phi) p_f`` (conservative form of syst2b) to
  O(dt^2) per step; with ``1 - phi^n`` on both sides the scheme would drop ``-p_f d_t phi``;
* ``K`` and the base-injection source ``s`` per gas law
  (:func:`granflow.physics.pore_pressure.gas_operator`): LINEAR ``K = p_atm kappa`` (syst2b),
  NONLINEAR ``K = kappa (p_atm + p_f^n)`` (eq. pressure-diffusion-nonlinear, lagged at ``p_f^n``);
  open top optional, impermeable walls and base otherwise;
* ``compressibility`` (:class:`granflow.gas.GasCompressibility`, LINEAR only): the capacity, the
  history and the transport terms are divided by the polytropic index n (1 isothermal, the
  default; 1.4 adiabatic), and so are the gas energy and the capacity terms of :class:`GasPowers`;
* ``p_atm Div u^{n+1}`` is implicit: the rows border the (u, p) saddle matrix
  (:class:`granflow.physics.momentum.GasBorder`), and the momentum rows get the full
  ``Grad p_f^{n+1}`` (syst3b). One monolithic solve per Picard sweep -- never a sequential pass,
  which is unstable (NUMERICS.md §3.3).

Energy (:class:`GasPowers`). Gas energy ``E_1 = sum (1 - phi) e(p_f) dV`` with the paper's LOG
density ``e(p) = (p_atm + p) ln(1 + p/p_atm) - p`` (= H(p) + p_atm, eq. H(p)); Darcy dissipation
``D = sum w_f kappa_f |Grad p_f|^2 dV`` with the pairing of :mod:`~granflow.physics.pore_pressure`
that is exact for the continuous equations *with* the solid moving: ``w_f = p_atm/(p_atm + p_f)``
for LINEAR, ``w_f = 1`` for NONLINEAR. Continuum: ``dE_1/dt + D + int p_f div u = P_inj``, and the
momentum equation receives ``+int p_f div u`` from ``-grad p_f``: the pressure work cancels.
Discretely, multiplying each gas row by ``e'(p_f^{n+1}) dV = ln(1 + p_f^{n+1}/p_atm) dV`` and
summing gives the EXACT identity (``p = p_f^{n+1}``, ``q = p_f^n``, sums over wet cells unless
stated)::

    (E_1^{n+1} - E_1^n)/dt + D + W_f - P_inj
        = - sum (1 - phi*) B(q, p) dV/dt                             backward Euler  (<= 0)
          - sum_{not wet} (1 - phi^n) e(q) dV/dt                     cells turned ambient (<= 0)
          - [sum (phi^{n+1} - phi*) e(p) + (phi* - phi^n)(e(q) - q e'(p))] dV/dt
          - sum e'(p) T dV - sum (p_atm e'(p) - p)(Div u) dV          transport/compression
          + D - sum e'(p) (L p) dV                                   diffusion (chain rule, weights)
          - p_atm sum e'(p) r_g dV                                   linear solve (0 if exact)

with ``W_f = dV sum p (Div u)`` the pressure work, ``B(q, p) = e(q) - e(p) - e'(p)(q - p) >= 0``
(Bregman divergence of the convex ``e``), ``L p`` the diffusion part of the gas matrix and
``P_inj = dV sum e'(p) s`` the injected power, ``r_g`` the solve's error on the scaled gas rows
(:meth:`GasSystem.scaled_rhs`). The transport/compression and diffusion terms
vanish in the continuum limit (they are the discrete versions of the chain-rule steps of the
continuous proof); they are reported, not hidden. The momentum side's pressure work
``-dV u . Grad p_f`` equals ``W_f`` because ``Grad = -Div^T`` (:attr:`GasPowers.work_momentum`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from granflow.errors import GranflowInputError
from granflow.grid import Grid
from granflow.materials import Material
from granflow.operators import Operators
from granflow.physics.momentum import GasBorder
from granflow.physics.pore_pressure import (GasCompressibility, GasLaw, darcy_dissipation, explicit_rhs,
                                            gas_operator, polytropic_index, transport_divergence)
from granflow.physics.transport import advect


def log_energy_density(p, p_atm: float) -> np.ndarray:
    """``e(p) = (p_atm + p) ln(1 + p/p_atm) - p`` [J m^-3] (paper eq. H(p) + p_atm), ``p > -p_atm``."""
    p = np.asarray(p, dtype=float)
    return (p_atm + p) * np.log1p(p / p_atm) - p


def log_energy_slope(p, p_atm: float) -> np.ndarray:
    """``e'(p) = ln(1 + p/p_atm)`` [-]."""
    return np.log1p(np.asarray(p, dtype=float) / p_atm)


@dataclass(frozen=True)
class GasPowers:
    """Gas-side energy terms of one step [W m^-1] (module docstring); the identity reads
    ``(E_1^{n+1} - E_1^n)/dt + darcy + work - injection = backward_euler + ambient + transport
    + diffusion``."""

    darcy: float
    """Darcy dissipation ``D`` at ``t^{n+1}`` (>= 0)."""
    work: float
    """Pressure work of p_f on the gas side, ``W_f = dV sum p_f Div u``."""
    work_momentum: float
    """The same work from the momentum rows, ``-dV u . Grad p_f`` (= ``work`` to round-off)."""
    injection: float
    """Injected power ``P_inj = dV sum e'(p_f) s``."""
    backward_euler: float
    """``-sum (1 - phi*) B(q, p) dV/dt`` (<= 0)."""
    ambient: float
    """``-sum (1 - phi^n) e(q) dV/dt`` over cells turned ambient (<= 0)."""
    transport: float
    """Transport / compression mismatch (-> 0 in the continuum limit)."""
    diffusion: float
    """``D - sum e'(p) (L p) dV``: chain rule and Darcy weight mismatch (-> 0 with dx)."""
    linear_solve: float = 0.0
    """``-p_atm dV sum e'(p) r_g``, ``r_g`` the linear solve's error on the scaled gas rows
    (:meth:`GasSystem.scaled_rhs`): round-off with a fresh PARDISO analysis, ~1e-9 of the other
    terms with a kept one."""

    @property
    def numerical(self) -> float:
        """Sum of the five numerical terms (right-hand side of the identity)."""
        return self.backward_euler + self.ambient + self.transport + self.diffusion + self.linear_solve


@dataclass(frozen=True)
class GasSystem:
    """The gas rows of one step, restricted to the wet cells (built by :meth:`GasCoupling.prepare`)."""

    wet: np.ndarray
    """bool (n_cells,)."""
    phi_star: np.ndarray
    """Predicted packing (n_cells,) [-] (capacity and kappa)."""
    phi_old: np.ndarray
    p_f_old: np.ndarray
    transport: np.ndarray
    """``T^n`` (n_cells,) [Pa s^-1]."""
    source: np.ndarray
    """Injection source ``s`` (n_cells,) [Pa s^-1]."""
    matrix: sp.csr_matrix
    """``M`` on the wet cells (n_wet, n_wet) [s^-1]."""
    rhs: np.ndarray
    """Right-hand side of the wet gas rows (n_wet,) [Pa s^-1] (unscaled)."""
    dt: float
    face_factor: np.ndarray | None = None
    """Multiplier of the face mobilities (indicator surface), else None."""

    @property
    def n_wet(self) -> int:
        return int(self.rhs.size)

    def border(self, p_atm: float) -> GasBorder:
        """The symmetric border block ``-M/p_atm`` of :meth:`SaddleAssembler.saddle`."""
        return GasBorder(self.wet, (-1.0 / p_atm) * self.matrix)

    def scaled_rhs(self, p_atm: float) -> np.ndarray:
        """Right-hand side of the scaled gas rows, ``-rhs/p_atm``."""
        return -self.rhs / p_atm

    def expand(self, p_wet) -> np.ndarray:
        """Flat ``p_f`` (n_cells,) [Pa] from the wet unknowns, zero elsewhere."""
        out = np.zeros(self.wet.size)
        out[self.wet] = p_wet
        return out


class GasCoupling:
    """Assembles the gas rows of each step and their energy terms.

    Parameters
    ----------
    grid : Grid
    ops : Operators
    material : Material
        d, eta_f, p_atm, phi_max.
    gas : GasLaw or str
    open_top : bool
        ``p_f = 0`` on the top wall face (otherwise impermeable; the ambient cells are always
        ``p_f = 0``).
    injection : float or array_like (nx,)
        Superficial gas velocity ``U_inj`` [m s^-1] through the porous base,
        ``-kappa dp_f/dz = U_inj`` (>= 0 upwards).
    compressibility : GasCompressibility or str
        ``"isothermal"`` (default, the paper's syst2b) or ``"adiabatic"`` (LINEAR only).
    """

    def __init__(self, grid: Grid, ops: Operators, material: Material, gas: GasLaw | str,
                 open_top: bool = False, injection=0.0,
                 compressibility: GasCompressibility | str = GasCompressibility.ISOTHERMAL) -> None:
        try:
            self.gas = GasLaw(gas)
        except ValueError:
            raise GranflowInputError(f"unknown gas law {gas!r}; expected one of "
                                     f"{[k.value for k in GasLaw]}") from None
        if self.gas is GasLaw.NONE:
            raise GranflowInputError('GasCoupling needs a gas law ("linear" or "nonlinear"), got "none"')
        u = np.asarray(injection, dtype=float)
        u = np.full(grid.nx, float(u)) if u.ndim == 0 else u
        if u.shape != (grid.nx,) or not np.all(np.isfinite(u)):
            raise GranflowInputError(f"injection must be a finite scalar or of shape ({grid.nx},)")
        self.grid, self.ops, self.material = grid, ops, material
        self.open_top = bool(open_top)
        self.injection = u
        self.polytropic = polytropic_index(self.gas, compressibility)
        """Polytropic index n of the gas [-] (1 isothermal)."""
        self.compressibility = GasCompressibility(compressibility)
        self.div, self.cell_weight, self.face_weight = ops.div, None, None
        if grid.axisymmetric:  # every gas row times its ring's 2 pi r_c (module docstring)
            from granflow.axisymmetric import AxisymmetricOperators

            self.div = AxisymmetricOperators.build(grid, ops.bcs).div
            self.cell_weight = np.repeat(grid.radial.cells[:, 0], grid.nz)
            self.face_weight = grid.unknown_metric

    def _faces(self, face_factor):
        """The face mobilities' multiplier: the indicator's ``face_factor`` times the faces'
        ``2 pi r`` on an axisymmetric grid (None: neither)."""
        if self.face_weight is None:
            return face_factor
        return self.face_weight if face_factor is None else self.face_weight * np.asarray(face_factor, dtype=float)

    def _on_cells(self, a):
        return a if self.cell_weight is None else self.cell_weight * a

    def prepare(self, phi, p_f, vel, dt: float, wet, face_factor=None) -> GasSystem:
        """Gas rows of the step from ``t^n`` fields (``phi``, ``p_f`` [Pa], ``vel``) and ``wet``
        (``face_factor``: multiplier of the face mobilities, :func:`gas_operator`).

        Raises
        ------
        GranflowInputError
            If the gas law cannot be evaluated (e.g. ``p_f <= -p_atm`` for NONLINEAR).
        """
        g, ops, mat = self.grid, self.ops, self.material
        phi_old = np.asarray(phi, dtype=float).ravel()
        q = np.asarray(p_f, dtype=float).ravel()
        wet = np.asarray(wet, dtype=bool).ravel()
        moving = np.any(np.asarray(vel) != 0.0)
        phi_star = (np.clip(advect(g, phi_old.reshape(g.cell_shape), vel, dt).phi.ravel(), 0.0, mat.phi_max)
                    if moving else np.clip(phi_old, 0.0, mat.phi_max))
        block = gas_operator(g, ops, phi_star, dt, mat, gas=self.gas, p_f=q, dirichlet=~wet,
                             open_top=self.open_top, injection=self.injection,
                             face_factor=self._faces(face_factor), cell_weight=self.cell_weight,
                             compressibility=self.compressibility)
        T = (transport_divergence(g, ops, np.clip(phi_old, 0.0, mat.phi_max), q, vel, self.div) if moving
             else np.zeros(g.n_cells))
        rhs = explicit_rhs(g, np.clip(phi_old, 0.0, mat.phi_max), q, dt, transport=T, dirichlet=~wet,
                           polytropic=self.polytropic)
        idx = np.flatnonzero(wet)
        M = block.matrix.tocsr()[idx][:, idx].tocsr()
        source = block.rhs if self.cell_weight is None else block.rhs / self.cell_weight
        return GasSystem(wet=wet, phi_star=phi_star, phi_old=phi_old, p_f_old=q, transport=T,
                         source=source, matrix=M, rhs=(self._on_cells(rhs) + block.rhs)[idx], dt=float(dt),
                         face_factor=self._faces(None if face_factor is None else np.asarray(face_factor, dtype=float)))

    def powers(self, system: GasSystem, p_f, vel, phi_new, row_residual=None) -> GasPowers:
        """Energy terms of the step (module docstring) for the solution ``p_f`` (n_cells,) [Pa],
        ``vel`` (``u^{n+1}``) and the transported, clipped ``phi_new``; ``row_residual`` (n_wet,):
        the solve's error on the scaled gas rows (None: 0)."""
        g, ops, mat = self.grid, self.ops, self.material
        pa, dV, dt = mat.p_atm, g.cell_volume, system.dt
        wet = system.wet
        p = np.asarray(p_f, dtype=float).ravel()
        q = system.p_f_old
        phi_s, phi_o, phi_n = system.phi_star, system.phi_old, np.asarray(phi_new, dtype=float).ravel()
        e_p, e_q, de_p = log_energy_density(p, pa), log_energy_density(q, pa), log_energy_slope(p, pa)
        div_u = self.div @ vel
        darcy = darcy_dissipation(g, ops, phi_s, p, mat, open_top=self.open_top,
                                  weighted=self.gas is GasLaw.LINEAR, face_factor=system.face_factor,
                                  cell_weight=self.cell_weight)
        pw = p[wet]
        n = self.polytropic  # the storage terms carry 1/n (1.0 isothermal: unchanged values)
        cap = self._on_cells((1.0 - phi_s) / (n * dt))[wet]
        Lp = system.matrix @ pw - cap * pw
        bregman = e_q - e_p - de_p * (q - p)
        w = self._on_cells  # axisymmetric: each cell's term over its ring
        transport = -float(np.sum(w((phi_n - phi_s) * e_p + (phi_s - phi_o) * (e_q - q * de_p))[wet]) / (n * dt)
                      + np.sum(w(de_p * system.transport)[wet]) / n
                      + np.sum(w((pa * de_p - p) * div_u)[wet]))
        grad_p = ops.grad @ p
        return GasPowers(
            darcy=darcy,
            work=dV * float(w(p) @ div_u),
            work_momentum=-dV * float(vel @ (grad_p if self.face_weight is None else self.face_weight * grad_p)),
            injection=dV * float(np.sum(w(de_p * system.source)[wet])),
            backward_euler=-dV * float(np.sum(w((1.0 - phi_s) * bregman)[wet])) / (n * dt),
            ambient=-dV * float(np.sum(w((1.0 - np.clip(phi_o, 0.0, mat.phi_max)) * e_q)[~wet])) / (n * dt),
            transport=dV * transport,
            diffusion=darcy - dV * float(de_p[wet] @ Lp),
            linear_solve=0.0 if row_residual is None else -pa * dV * float(de_p[wet] @ row_residual),
        )
