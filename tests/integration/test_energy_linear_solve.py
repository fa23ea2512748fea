"""The energy budget's ``linear_solve`` terms (granflow.diagnostics.EnergyBudget): the power of the
linear solve's error, ``dV r_u . u`` on the velocity rows and ``-p_atm dV e'(p_f) . r_g`` on the
scaled gas rows (``r = K x - b`` of the step's last solve).

Dotting the discrete momentum equation with ``u^{n+1} dV`` (and the gas rows with ``e'(p_f) dV``)
gives the split identity, numerical terms summing to the budget's residual, only for an exact
solve; an inexact one adds exactly these powers. Test: every solution of the dry and the fluidised
collapse is perturbed here by a relative 1e-6 (a solve far less accurate than any solver's), the
budget's terms must still sum to its residual to round-off, and without the two terms they must
not (the control, so the terms are not round-off themselves)."""
from __future__ import annotations

import numpy as np
import pytest

from granflow import step
from granflow.grid import Grid
from granflow.model import Model
from granflow.rheology import make_closure
from granflow.simulation import Simulation

MATERIAL = dict(d=70e-6, rho_s=2500.0, phi_max=0.6)
ERROR = 1e-6
"""Relative perturbation of every solution [-]."""


@pytest.mark.parametrize("gas", [None, "linear", "nonlinear"])
def test_an_inexact_solve_is_booked_and_the_split_stays_exact(monkeypatch, gas):
    rng = np.random.default_rng(7)
    solve = step._solve

    def inexact(*args, **kw):
        sol, its, _ = solve(*args, **kw)  # the solver's K x - b belongs to the unperturbed solution:
        return sol * (1.0 + ERROR * rng.standard_normal(sol.size)), its, None  # None, the step recomputes it

    monkeypatch.setattr(step, "_solve", inexact)
    g = Grid(nx=40, nz=15, Lx=0.4, Lz=0.15)
    model = Model(g, make_closure("drucker_prager", material=MATERIAL, delta_deg=26.74), gas=gas)
    X, Z = g.cell_coords()
    phi = np.where((X < 0.1) & (Z < 0.1), 0.6 if gas is None else 0.58, 0.0)
    p_f = 0.0 if gas is None else 0.9 * model.lithostatic_pressure(phi)
    sim = Simulation(model, model.initial_state(phi, p_f=p_f), stop_time=0.02)
    sim.run()
    b = sim.budget
    assert b.released > 0
    total = sum(b.numerical.values())
    booked = b.numerical["linear_solve"] + b.numerical["gas_linear_solve"]
    tolerance = 1e-12 * b.released
    assert total == pytest.approx(b.residual, rel=1e-10, abs=tolerance)
    assert abs(b.numerical["linear_solve"]) > 1e3 * tolerance
    if gas is not None:
        assert abs(b.numerical["gas_linear_solve"]) > 1e3 * tolerance
        assert b.residual_gas == pytest.approx(sum(v for k, v in b.numerical.items() if k.startswith("gas_")),
                                               rel=1e-10, abs=tolerance)
    else:
        assert b.numerical["gas_linear_solve"] == 0.0
    assert abs(total - booked - b.residual) > 1e2 * tolerance  # control: not round-off
