"""A closure is one file, and nothing else is edited (issue 18 item 4): a closure module written at
test time into ``tmp_path`` and put on the package path of ``granflow.rheology`` (a monkeypatch of
its ``__path__``; :func:`granflow.rheology.discover` imports it by the registry's pkgutil rule) is
listed by ``granflow list closures``, passes the checks every non-reference closure of the
registry passes (the loop of tests/unit/test_conditions.py, :mod:`_closure_checks`) and runs a tiny
column collapse through :class:`granflow.simulation.Simulation`. The module, its registration and
the path are undone afterwards.
"""
from __future__ import annotations

import json
import sys
import textwrap

import numpy as np
import pytest

import granflow.rheology as rheology_pkg
from _closure_checks import assert_c1_and_equilibrium
from granflow.cli import ExitCode, main
from granflow.diagnostics import mass
from granflow.grid import Grid
from granflow.model import Model, StepStatus
from granflow.rheology import CLOSURES, make_closure
from granflow.simulation import Simulation

NAME = "tmp_constant_friction"
MU = 0.45
"""Z = mu of the temporary closure [-] (a Drucker-Prager law, tan 24.2 deg)."""

MODULE = f'''
"""A closure kept in a test's temporary directory: Z = mu, f from C1 (paper eq. f-general)."""
from typing import ClassVar

import numpy as np
from pydantic import Field

from granflow.rheology.base import CLOSURES, Closure, _arr


def _shape(phi, I):
    return np.broadcast(_arr(phi), _arr(I)).shape


@CLOSURES.register("{NAME}")
class TmpConstantFriction(Closure):
    """Constant friction Z = mu (test closure)."""

    summary: ClassVar[str] = "Z = mu (test closure)"
    mu: float = Field({MU}, gt=0, description="friction coefficient [-]")

    def Z(self, phi, I):
        return np.full(_shape(phi, I), self.mu)

    def dZ_dI(self, phi, I):
        return np.zeros(_shape(phi, I))

    dZ_dphi = dZ_dI

    # C1: Z - I Z'/2 = (I f)', so I f = mu I - B(phi), B = mu I_eq(phi).
    def A(self, phi, I):
        return np.full(_shape(phi, I), self.mu)

    dA_dI = dZ_dI
    dA_dphi = dZ_dI

    def B(self, phi):
        return self.mu * self.I_eq(phi)

    def dB_dphi(self, phi):
        return self.mu * self.equilibrium.dI_eq_dphi(phi)
'''


@pytest.fixture
def plugin(tmp_path, monkeypatch):
    """The closure module in ``tmp_path``, on the package path, discovered; undone afterwards."""
    (tmp_path / f"{NAME}.py").write_text(textwrap.dedent(MODULE))
    assert NAME not in CLOSURES
    monkeypatch.setattr(rheology_pkg, "__path__", [*rheology_pkg.__path__, str(tmp_path)])
    try:
        yield rheology_pkg.discover()
    finally:
        CLOSURES.remove(NAME)
        sys.modules.pop(f"granflow.rheology.{NAME}", None)


def test_a_closure_in_a_temporary_module_is_listed_checked_and_runs(plugin, capsys):
    assert f"granflow.rheology.{NAME}" in plugin

    # granflow list closures (text and JSON)
    assert main(["list", "closures"]) == ExitCode.OK
    assert NAME in capsys.readouterr().out
    assert main(["list", "closures", "--json"]) == ExitCode.OK
    listed = json.loads(capsys.readouterr().out)
    assert listed[NAME]["summary"] == "Z = mu (test closure)" and listed[NAME]["reference"] is False

    # the checks loop of the registry (tests/unit/test_conditions.py), the new closure among them
    checked = []
    for name in CLOSURES:
        closure = make_closure(name)
        if not closure.reference:
            assert_c1_and_equilibrium(closure)
            checked.append(name)
    assert NAME in checked
    closure = make_closure(NAME)
    phi = np.array([0.5, 0.58])[:, None]
    I = closure.I_eq(phi) * np.array([0.5, 2.0])[None, :]
    assert np.allclose(closure.f(phi, 1e3, I), MU * (1 - closure.I_eq(phi) / I), rtol=1e-12)

    # a tiny column collapse with it
    g = Grid(nx=8, nz=6, Lx=0.08, Lz=0.06)
    model = Model(g, make_closure(NAME, material=dict(d=70e-6, phi_max=0.6)))
    X, Z = g.cell_coords()
    state = model.initial_state(np.where((X < 0.03) & (Z < 0.04), 0.6, 0.0))
    m0 = mass(g, state.phi)
    sim = Simulation(model, state, stop_time=1.0, max_steps=4)
    sim.run()
    assert state.step == 4 and all(r.status is not StepStatus.FAILED for r in sim.reports)
    assert np.all(np.isfinite(state.vel)) and np.all(np.isfinite(state.p))
    assert mass(g, state.phi) == pytest.approx(m0, rel=1e-10)


def test_the_temporary_closure_is_gone_afterwards():
    assert NAME not in CLOSURES
    assert f"granflow.rheology.{NAME}" not in rheology_pkg.discover()
