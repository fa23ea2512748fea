"""The geometry of :class:`granflow.model.Model` (a mixin; issue 14 item 4): the volume weights of
the discrete equations and the operators that change with them.

A plane model works per unit width and every weight is 1 (the attributes below are None and the
plane code paths run unchanged). On an axisymmetric grid (``Grid(geometry="axisymmetric")``, x the
radius r) every control volume is a ring of circumference ``2 pi r``:

* a momentum row (a u or w face's dual cell) is multiplied by ``2 pi r`` of the unknown
  (:attr:`granflow.grid.Grid.unknown_metric`; ``r_f`` for u, ``r_c`` for w), a continuity
  (dilatancy) row by ``2 pi r_c`` (:attr:`cell_weight`); with the viscous operator and gradient
  of :meth:`granflow.axisymmetric.AxisymmetricOperators.assembly_operators` the saddle-point system
  stays symmetric, ``[[M rho/dt + V, W_f grad], [(W_f grad)^T, -W_c C]]``;
* the strain rate has the hoop component ``u/r`` and ``|S|`` is the three-dimensional deviator's
  (:attr:`strain_rows`), the divergence is ``(1/r) d(r u)/dr + dw/dz`` (:attr:`divergence`);
* the dual cell of a u face straddles two rings of different volumes, so its solid fraction is
  the volume-weighted mean ``(r_L phi_L + r_R phi_R)/(2 r_f)`` (:meth:`dual_mean`), which makes
  its mass follow the momentum transport's dual fluxes exactly
  (:func:`granflow.physics.momentum_transport.axisymmetric_transport`);
* every integral of the budget (mass, energies, powers) is over the full cylinder [kg, J, W];
* the gas rows are weighted the same way by :class:`granflow.physics.coupling.GasCoupling`.

What an axisymmetric model does not support yet is refused by name (:meth:`_check_geometry`).
"""
from __future__ import annotations

from functools import cached_property

import numpy as np

from granflow.axisymmetric import AxisymmetricOperators
from granflow.errors import GranflowInputError
from granflow.grid import VelocityBC
from granflow.strain_rate import StrainRate


class GeometryWeights:
    """Geometry of :class:`granflow.model.Model` (a mixin; reads ``grid``, ``ops``)."""

    @cached_property
    def axisymmetric_operators(self) -> AxisymmetricOperators | None:
        """The (r, z) operators of an axisymmetric grid, else None."""
        if not self.grid.axisymmetric:
            return None
        return AxisymmetricOperators.build(self.grid, self.ops.bcs)

    def assembly_operators(self):
        """What :class:`granflow.physics.momentum.SaddleAssembler` is built from."""
        axi = self.axisymmetric_operators
        return self.ops if axi is None else axi.assembly_operators()

    @cached_property
    def unknown_weight(self) -> np.ndarray | None:
        """``2 pi r`` at the velocity unknowns [m] (None: plane)."""
        return self.grid.unknown_metric

    @cached_property
    def cell_weight(self) -> np.ndarray | None:
        """``2 pi r_c`` at the cells, (n_cells,) [m] (None: plane)."""
        rad = self.grid.radial
        return None if rad is None else np.repeat(rad.cells[:, 0], self.grid.nz)

    def on_unknowns(self, a):
        """``a`` times :attr:`unknown_weight` (``a`` itself in a plane)."""
        return a if self.unknown_weight is None else self.unknown_weight * a

    def on_cells(self, a):
        """``a`` times :attr:`cell_weight` (``a`` itself in a plane)."""
        return a if self.cell_weight is None else self.cell_weight * a

    @cached_property
    def divergence(self):
        """``div u`` at the cells [m^-1] (sparse, (n_cells, n_unknowns))."""
        axi = self.axisymmetric_operators
        return self.ops.div if axi is None else axi.div

    @cached_property
    def strain_rows(self) -> tuple:
        """Cell rows ``R_k`` with ``|S|^2 = sum_k (R_k u)^2/4 + mean(S_xz^2)``: ``(ec,)`` in a
        plane, the three scaled pair rows of :attr:`AxisymmetricOperators.strain_rows`."""
        axi = self.axisymmetric_operators
        return (self.ops.ec,) if axi is None else axi.strain_rows

    def strain_rate_on(self, cells):
        """``|S|`` on the cells of a mask, as a callable of the velocity (the plane
        :meth:`granflow.operators.Operators.strain_rate_on`)."""
        if self.axisymmetric_operators is None:
            return self.ops.strain_rate_on(cells)
        rate = self.__dict__.get("_strain_rate")
        if rate is None or rate.source is not self.strain_rows:  # built once for the rows
            rate = self.__dict__["_strain_rate"] = StrainRate(self.ops, self.strain_rows)
        return rate.on(cells)

    def dual_mean(self, phi) -> np.ndarray:
        """The cells' field at the velocity unknowns as the volume-weighted mean of each face's
        dual cell (module docstring): ``cell_to_face @ phi`` in a plane."""
        phi = np.ravel(phi)
        if self.cell_weight is None:
            return self.ops.cell_to_face @ phi
        return (self.ops.cell_to_face @ (self.cell_weight * phi)) / self.unknown_weight

    def dissipation(self, vel, eta_c, eta_n) -> float:
        """``dV u^T V u`` [W m^-1; W on an axisymmetric grid] (the yield and viscous dissipation)."""
        axi = self.axisymmetric_operators
        if axi is None:
            return self.ops.dissipation(vel, eta_c, eta_n)
        return 2.0 * np.pi * axi.dissipation(vel, eta_c, eta_n)

    def _check_geometry(self, amg: bool) -> None:
        """What an axisymmetric model does not support yet (issue 14 item 4), named."""
        if not self.grid.axisymmetric:
            return
        unsupported = [(not self.indicator, f"surface = {self.surface.value!r} (needs 'indicator')"),
                       (self.advection.value != "consistent",
                        f"advection = {self.advection.value!r} (needs 'consistent')"),
                       (amg, "linear_solver = 'amg' (use 'direct' or 'pardiso')"),
                       (self.source is not None, "an inflow source"),
                       (self.solid is not None, "a topography"),
                       (self.outflow, "an outflow wall"),
                       (self.gravity[0] != 0.0, "a gravity with a radial component (slope_deg = 0)"),
                       (self.wall_friction is not None, "a Coulomb base (bcs.bottom = 'coulomb')"),
                       (self.ops.bcs.west is not VelocityBC.FREE_SLIP,
                        "a west wall other than free-slip (the west side is the axis)")]
        bad = [what for flag, what in unsupported if flag]
        if bad:
            raise GranflowInputError(f"Model: an axisymmetric grid does not support {'; '.join(bad)} yet")
