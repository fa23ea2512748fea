"""Coulomb friction on the base (``walls.bottom = "coulomb"``): smooth and rough channel bases.

A base of wall friction angle ``delta_w`` (coefficient ``mu_w = tan(delta_w)`` [-]) carries at most
the tangential stress ``mu_w p_wall`` [Pa], ``p_wall`` the granular (effective) pressure on it
(:func:`granflow.physics.momentum.base_pressure`; the gas's share of the weight is not friction):

    |tau_b| = min(|tau_interior|, mu_w p_wall),   the grains slide on the base when the cap acts.

Discretisation (MAC grid, :mod:`granflow.operators`). The base keeps the no-slip ghost
(``u_ghost = -u_1``), so the shear rate of a base node is ``gamma_w = (en u)_node = 2 u_1 / dz``
and its stress ``eta_n gamma_w``: the half cell between the wall and the first row of x-faces is
the slip layer, ``u_1`` the slip velocity. The friction enters only through that node's
viscosity, capped by the regularised Coulomb viscosity of the wall

    eta_w = mu_w p_wall / sqrt(gamma_w^2 + (2 eps)^2),      eta_n <- min(eta_n, eta_w)   [Pa s]

(the regularisation of the interior's yield viscosity, ``|S| = gamma/2``,
:func:`granflow.physics.momentum.yield_viscosity`; ``eps`` the model's regularisation strain rate
[s^-1]): the stress tends to ``mu_w p_wall`` once ``|u_1| >> eps dz``, and below the cap the
base node keeps the interior's viscosity, i.e. the no-slip base. ``gamma_w`` is the Picard loop's
lagged velocity, so the cap is updated at every sweep like the interior viscosity. The slip is
not a deformation of the grains: the bottom cells' strain rate (which sets their viscosity and
dilatancy) counts only the share ``eta_n'/eta_n`` of the base nodes' shear rate, from the previous
sweep (:func:`strain_rate_norm`). A rigid layer on a slope ``theta`` with ``mu_w < tan(theta)`` (and an interior stronger than ``mu_w``) then
accelerates at ``g (sin(theta) - mu_w cos(theta))``; with ``mu_w > tan(theta)`` it stays at rest
(creeping at speeds ~ eps dz) -- the tests of tests/integration/test_wall_friction.py.

With gas, ``p_wall`` uses the pore-pressure gradient of the bottom cells, so a fluidised base
(``p_wall = 0``) is frictionless: the smooth/rough distinction fades as the flow is fluidised.
"""
from __future__ import annotations

import numpy as np

from granflow.physics.momentum import base_pressure

INITIAL_SHARE = 0.0
"""Material share of the base shear assumed at a step's first Picard sweep: all slip (at 1, the
whole base shear, a sliding layer's bottom cells start weak and dilating, and at the default
``picard.tol`` a sliding block's speed came out 2.8 % low after 100 steps of 1 ms, at 0 within
0.05 %: the Picard fixed point does not depend on it, the iterate where the default tolerance
stops does)."""
REG_FACTOR = 2.0
"""``gamma_w`` regularisation = REG_FACTOR * eps: the node shear rate is twice |S| in simple shear."""


def wall_pressure(model, phi_e, p_eval, p_f) -> np.ndarray:
    """Granular pressure on the base under each bottom cell [Pa], shape ``(nx,)``: the bottom
    cells' pressure extrapolated to the wall with the pore-pressure gradient of the first interior
    z-face (:func:`granflow.physics.momentum.base_pressure`)."""
    g = model.grid
    nx, nz = g.cell_shape
    cols, jb = np.arange(nx), model.base_index  # the base cells (the lowest fluid cells)
    p2 = np.asarray(p_eval, dtype=float).reshape(nx, nz)
    phi2 = np.asarray(phi_e, dtype=float).reshape(nx, nz)
    pf2 = np.asarray(p_f, dtype=float).reshape(nx, nz)
    dpf = (pf2[cols, jb + 1] - pf2[cols, jb]) / g.dz if nz > 1 else 0.0
    return base_pressure(p2[cols, jb], phi2[cols, jb], model.material.rho_s, abs(model.gravity[1]), g.dz, dpf)


def coulomb_base_viscosity(model, phi_e, p_eval, p_f, vel, eta_n) -> tuple[np.ndarray, np.ndarray]:
    """``eta_n`` with the base nodes capped at the Coulomb viscosity ``eta_w`` (module docstring)
    [Pa s], the other nodes unchanged; and the base nodes' material share ``r = eta_n' / eta_n``
    in [0, 1] of their shear rate (1: the base holds, 0: all slip; :func:`strain_rate_norm`).

    Parameters
    ----------
    model : granflow.model.Model
        With ``model.wall_friction`` = mu_w [-] and a ``"coulomb"`` base.
    phi_e, p_eval, p_f : array_like, (n_cells,)
        Packing [-], granular pressure [Pa] and pore pressure [Pa] of the Picard sweep.
    vel : array_like, (n_unknowns,)
        The sweep's lagged velocity [m s^-1].
    eta_n : array_like, (n_nodes,)
        Node viscosity of the interior closure [Pa s].
    """
    nodes, to_nodes = model.base_node_rows
    nx, nz = model.grid.cell_shape
    p_cells = np.zeros((nx, nz))
    p_cells[np.arange(nx), model.base_index] = wall_pressure(model, phi_e, p_eval, p_f)
    p_node = to_nodes @ p_cells.ravel()
    gamma = (model.ops.en @ np.asarray(vel, dtype=float))[nodes]
    eta_w = model.wall_friction * p_node / np.sqrt(gamma * gamma + (REG_FACTOR * model.eps) ** 2)
    out = np.array(eta_n, dtype=float)
    interior = out[nodes]
    out[nodes] = np.minimum(interior, eta_w)
    share = np.divide(out[nodes], interior, out=np.ones_like(interior), where=interior > 0.0)
    return out, share


def strain_rate_norm(model, vel, share=None) -> np.ndarray:
    """The grains' ``|S|`` at cell centres [s^-1] over a Coulomb base: as
    :meth:`granflow.operators.Operators.strain_rate_norm`, with each base node's shear rate
    weighted by its material share ``r`` (:func:`coulomb_base_viscosity`), so that the slip on
    the base (the part ``1 - r`` of ``2 u_1 / dz``) neither dilates nor weakens the bottom cells.
    ``share`` None (the first sweep of a step): :data:`INITIAL_SHARE`."""
    ops = model.ops
    vel = np.asarray(vel, dtype=float)
    nodes, _ = model.base_node_rows
    en_u = ops.en @ vel
    en_u[nodes] *= INITIAL_SHARE if share is None else share
    return np.sqrt(0.25 * (ops.ec @ vel) ** 2 + 0.25 * (ops.node_to_cell @ en_u ** 2))


def base_shear_stress(model, vel, eta_n) -> np.ndarray:
    """Tangential stress of the base nodes ``eta_n (en u)`` [Pa], shape ``(nx + 1,)`` (the force
    per unit area the base exerts is minus this; diagnostics and tests)."""
    nodes, _ = model.base_node_rows
    return (np.asarray(eta_n, dtype=float) * (model.ops.en @ np.asarray(vel, dtype=float)))[nodes]


def base_strain_rate_norm(ops, vel, rows=None) -> np.ndarray:
    """``|S|`` at the base of each bottom cell [s^-1], shape ``(nx,)``.

    As :meth:`granflow.operators.Operators.strain_rate_norm` but with ``S_xz^2`` averaged over the
    cell's two bottom nodes only (on the wall), so that the base's shear stress ``2 eta S_xz`` of
    a viscosity ``Z p / (2 |S|)`` evaluated at it is ``Z p`` in simple shear, whatever the profile
    above: the centre's 4-node mean gives ``|S|`` half-way up the cell, ``1/sqrt(2)`` of the wall's
    in a film one cell thick with a stress-free top (basal friction ``sqrt(2) Z p``). Used by the
    ``"wall"`` base friction on a no-slip base (:func:`granflow.step.base_node_viscosity`).
    ``rows``: ``(ec, en_left, en_right)`` restricted to the base cells and their bottom-left and
    bottom-right nodes (:attr:`granflow.model.Model.base_strain_rows`, which follows a topography;
    on an axisymmetric grid ``ec`` is the tuple of the three scaled pair rows, the hoop strain
    included;
    the same values, ~20x fewer operations at 128^2); else the whole-grid operators on the bottom row.
    """
    vel = ops._velocity(vel)
    g = ops.grid
    nx, nz = g.cell_shape
    if rows is None:
        sxx2 = (0.25 * (ops.ec @ vel) ** 2).reshape(nx, nz)[:, 0]
        sxz2 = (0.25 * (ops.en @ vel) ** 2).reshape(g.node_shape)[:, 0]
        left, right = sxz2[:-1], sxz2[1:]
    elif isinstance(rows[0], tuple):  # axisymmetric: the three scaled pair rows
        sxx2 = 0.25 * sum((r @ vel) ** 2 for r in rows[0])
        left, right = 0.25 * (rows[1] @ vel) ** 2, 0.25 * (rows[2] @ vel) ** 2
    else:
        sxx2 = 0.25 * (rows[0] @ vel) ** 2
        left, right = 0.25 * (rows[1] @ vel) ** 2, 0.25 * (rows[2] @ vel) ** 2
    return np.sqrt(sxx2 + 0.5 * (left + right))
