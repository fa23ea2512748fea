"""An outflow wall (``walls.east = "outflow"``, issue 14 item 2): grains leave the box at x = Lx.

The east column of cells is an **absorbing column**. The implicit (u, p, p_f) solve sees a closed
box with a free-slip east wall, as for ``"free_slip"``; after each step's transport, the grains
that the step moved into the last column (``i = nx - 1``) are taken out of the box: their solid
volume is counted as outflow in the mass budget and the kinetic and potential energy they carry
as outflow in the energy budget
(:class:`granflow.diagnostics.EnergyBudget`). The column is therefore empty at the start of every
step, and the material upstream of it meets no wall: its east face is a free surface where
p = p_f = 0 (a free overfall, the brink of a cliff). The flow that reaches the last column is
not decelerated by the boundary; the price is that the last column is not part of the flow
domain (the run-out of the grains left in the box ends at ``Lx - dx``).

Budgets, per step (``dV = dx dz`` [m^2], column ``C`` = the cells ``(nx - 1, j)``):

* volume out ``m_out = sum_C phi dV`` [m^2 per unit width] (``phi`` the solid fraction): the
  mass identity becomes ``M(t) + M_out(t) = M(0)`` (plus the clipping terms), exactly, since the
  removal only zeroes cells;
* ``E_p,out = -rho_s sum_C phi (g . x_c) dV`` [J m^-1], the potential energy the grains take away
  (the convention of :func:`granflow.diagnostics.potential_energy`);
* ``E_k,out = 1/2 dV sum_f (rho_f(phi) - rho_f(phi')) u_f^2`` [J m^-1], the kinetic energy lost
  by the faces whose inertia the removal lowers (``phi'`` the fields after the removal, ``rho_f``
  the model's face inertia :meth:`granflow.model.Model.inertia_density`);
* ``E_1,out = E_1(phi, p_f) - E_1(phi', p_f')`` [J m^-1], the gas energy
  (:func:`granflow.physics.pore_pressure.gas_energy`), ``p_f' = 0`` in the column. In a run this
  is 0: the column is empty at the start of every step, so it has no gas row and its ``p_f`` is
  already 0 (the grains' gas drains to the atmosphere at the brink); the term is there for
  :func:`exchange`'s other use, a source's refill.

An inflow (source) boundary is :mod:`granflow.physics.inflow`; it books what it puts in with
:func:`exchange`, negated. A west outflow is not implemented.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from granflow.physics.material_surface import packing
from granflow.physics.pore_pressure import GasEnergy, gas_energy


@dataclass(frozen=True)
class Absorbed:
    """What one step's absorbing column took out of the box."""

    volume: float = 0.0
    """Solid volume per unit width [m^2]."""
    kinetic: float = 0.0
    """Kinetic energy [J m^-1]."""
    potential: float = 0.0
    """Potential energy [J m^-1] (zero at the grid's origin)."""
    gas: float = 0.0
    """Gas energy [J m^-1] (0 for the dry model)."""


    def negated(self) -> Absorbed:
        """The same exchange the other way (what an inflow put in, as a positive quantity)."""
        return Absorbed(volume=-self.volume, kinetic=-self.kinetic, potential=-self.potential, gas=-self.gas)


NOTHING = Absorbed()
"""A step that took nothing out."""


def _gas_energy(model, phi, c, p_f) -> float:
    psi = phi if c is None else packing(c, phi)
    return gas_energy(model.grid, psi, p_f, model.material, GasEnergy.LOG,
                      polytropic=getattr(getattr(model, "gas_coupling", None), "polytropic", 1.0))


def exchange(model, before: tuple, after: tuple, vel) -> Absorbed:
    """What changing the fields from ``before`` to ``after`` took out of the box (negative: what
    it put in; module docstring): each a tuple ``(phi (nx, nz), c or None, p_f or None)``, ``vel``
    the velocity unknowns [m s^-1]."""
    g = model.grid
    (phi, c, p_f), (phi2, c2, p_f2) = before, after
    phi, phi2 = np.asarray(phi, dtype=float), np.asarray(phi2, dtype=float)
    gx, gz = model.gravity
    X, Z = g.cell_coords()
    dV = g.cell_volume
    dphi = phi - phi2
    potential = -model.material.rho_s * dV * float(np.sum(dphi * (gx * X + gz * Z)))
    u = np.asarray(vel, dtype=float)
    kinetic = 0.5 * dV * float((model.inertia_density(phi) - model.inertia_density(phi2)) @ (u * u))
    gas = 0.0
    if p_f is not None:
        gas = (_gas_energy(model, phi, c, np.reshape(p_f, g.cell_shape))
               - _gas_energy(model, phi2, c2, np.reshape(p_f2, g.cell_shape)))
    return Absorbed(volume=float(np.sum(dphi)) * dV, kinetic=kinetic, potential=potential, gas=gas)


def absorb(model, phi, c, vel, p_f) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None, Absorbed]:
    """Empty the east column (module docstring).

    Parameters
    ----------
    model : granflow.model.Model
    phi : array (nx, nz)
        Solid fraction after the step's transport [-].
    c : array (nx, nz) or None
        Material fraction (indicator surface), else None.
    vel : array (n_unknowns,)
        Velocity ``u^{n+1}`` [m s^-1].
    p_f : array (nx * nz,) or None
        Pore pressure of the step [Pa] (None for the dry model).

    Returns
    -------
    phi, c, p_f : the fields with the column emptied (copies; the inputs when nothing left)
    absorbed : Absorbed
    """
    g = model.grid
    if not np.any(np.asarray(phi)[-1, :] != 0.0) and (c is None or not np.any(np.asarray(c)[-1, :] != 0.0)):
        return phi, c, p_f, NOTHING
    phi_out = np.array(phi, dtype=float)
    phi_out[-1, :] = 0.0
    c_out = None
    if c is not None:
        c_out = np.array(c, dtype=float)
        c_out[-1, :] = 0.0
    p_f_out = p_f
    if p_f is not None:
        p_f_out = np.array(p_f, dtype=float).reshape(g.cell_shape)
        p_f_out[-1, :] = 0.0
        p_f_out = p_f_out.reshape(np.shape(p_f))
    return phi_out, c_out, p_f_out, exchange(model, (phi, c, p_f), (phi_out, c_out, p_f_out), vel)
