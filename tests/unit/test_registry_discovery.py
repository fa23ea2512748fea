"""Registries find their parts (issue 18 item 4): a closure or a case is one file, no edit elsewhere.

``granflow.rheology`` and ``granflow.cases`` import every module of their package except those
named in their ``INFRASTRUCTURE`` tuple, if any (:func:`granflow.registry.discover_modules`). Here:

* a closure written at test time into a temporary directory, handed to
  ``granflow.rheology.discover(paths=[...])``, is listed by ``CLOSURES``, passes the registry-wide
  theory checks of tests/unit/test_conditions.py and tests/unit/test_closures.py, and drives a
  :class:`granflow.model.Model` for a few steps;
* a case written the same way is listed by ``CASES``, validated by ``granflow.config`` and set up;
* every module of both packages is either a part module (it registers at least one part) or
  declared infrastructure (and registers none); a module that is neither fails the test.

Each temporary part is unregistered, its module forgotten and its directory removed from the
package's ``__path__`` afterwards, so the registry-wide tests elsewhere see the usual registries.
"""
from __future__ import annotations

import json
import pkgutil
import sys
import textwrap
from contextlib import contextmanager

import numpy as np
import pytest

import granflow.cases as cases_pkg
import granflow.rheology as rheology_pkg
from granflow.cases import CASES
from granflow.config import validate
from granflow.grid import Grid
from granflow.model import Model, StepStatus
from granflow.rheology import CLOSURES, make_closure
from granflow.state import State
from _closure_checks import assert_c1_and_equilibrium
from granflow.theory.conditions import check

A, B = 0.4, 0.3
"""Z = a + b I of the temporary closure."""

CLOSURE_MODULE = f'''
"""A closure kept outside the source tree: Z = a + b I, f from C1."""
from typing import ClassVar

import numpy as np
from pydantic import Field

from granflow.rheology.base import CLOSURES, Closure, _arr


@CLOSURES.register("tmp_linear_yield")
class TmpLinearYield(Closure):
    summary: ClassVar[str] = "Z = a + b I (test closure)"
    a: float = Field({A}, gt=0)
    b: float = Field({B}, ge=0)

    def Z(self, phi, I):
        return self.a + self.b * np.broadcast_to(_arr(I), np.broadcast(_arr(phi), _arr(I)).shape)

    def dZ_dI(self, phi, I):
        return np.full(np.broadcast(_arr(phi), _arr(I)).shape, self.b)

    def dZ_dphi(self, phi, I):
        return np.zeros(np.broadcast(_arr(phi), _arr(I)).shape)

    # C1: Z - I Z'/2 = (I f)', so I f = a I + b I^2/4 - B(phi), B = I_eq (a + b I_eq/4).
    def A(self, phi, I):
        return self.a + 0.25 * self.b * np.broadcast_to(_arr(I), np.broadcast(_arr(phi), _arr(I)).shape)

    def dA_dI(self, phi, I):
        return np.full(np.broadcast(_arr(phi), _arr(I)).shape, 0.25 * self.b)

    dA_dphi = dZ_dphi

    def B(self, phi):
        ieq = self.I_eq(phi)
        return ieq * (self.a + 0.25 * self.b * ieq)

    def dB_dphi(self, phi):
        ieq = self.I_eq(phi)
        return self.equilibrium.dI_eq_dphi(phi) * (self.a + 0.5 * self.b * ieq)
'''

CASE_MODULE = '''
"""A case kept outside the source tree: a layer at rest (as static_layer), its own [setup]."""
from pydantic import Field

from granflow.cases.common import make_model, make_simulation, rectangle_fraction
from granflow.cases.registry import CASES
from granflow.config import Section
from granflow.state import State


class TmpLayerSetup(Section):
    H: float = Field(0.05, gt=0)


@CASES.register("tmp_layer", setup_model=TmpLayerSetup, summary="test case")
def setup(config):
    model = make_model(config)
    g = model.grid
    phi = config.material.phi_max * rectangle_fraction(g, 0.0, g.Lx, 0.0, config.setup.H)
    return make_simulation(config, model, State.at_rest(g, phi))
'''


@contextmanager
def extra_part(package, tmp_path, module: str, source: str, part: str, unregister):
    """Write ``module`` into ``tmp_path``, discover it as a module of ``package``, then undo it."""
    (tmp_path / f"{module}.py").write_text(textwrap.dedent(source))
    full = f"{package.__name__}.{module}"
    assert part not in (CLOSURES if package is rheology_pkg else CASES)
    try:
        found = package.discover(paths=[str(tmp_path)])
        yield found
    finally:
        unregister(part)
        sys.modules.pop(full, None)
        if str(tmp_path) in package.__path__:
            package.__path__.remove(str(tmp_path))


def part_modules(package) -> set[str]:
    """Modules that define a registered part of ``package``."""
    if package is rheology_pkg:
        return {CLOSURES.get(n).__module__ for n in CLOSURES.names()}
    return {CASES.get(n).setup.__module__ for n in CASES.names()}


def unaccounted(package) -> list[str]:
    """Problems of the discovery rule for ``package`` (empty when every module is accounted for):
    a module neither discovered nor infrastructure, a discovered module that registers no part,
    an infrastructure module that registers one, an infrastructure name with no module."""
    name = package.__name__
    modules = {f"{name}.{m.name}" for m in pkgutil.iter_modules(package.__path__)
               if not m.name.startswith("_")}
    infra = {f"{name}.{m}" for m in getattr(package, "INFRASTRUCTURE", ())}  # granflow.cases: none
    found = set(package.discover())
    parts = part_modules(package)
    problems = [f"{m}: neither discovered nor infrastructure" for m in sorted(modules - found - infra)]
    problems += [f"{m}: discovered but registers nothing" for m in sorted(found - parts)]
    problems += [f"{m}: infrastructure but registers a part" for m in sorted(infra & parts)]
    problems += [f"{m}: declared infrastructure, no such module" for m in sorted(infra - modules)]
    return problems


# ---- a new closure is one file -------------------------------------------------------------------
def test_closure_in_a_new_file_is_discovered_checked_and_runs(tmp_path):
    with extra_part(rheology_pkg, tmp_path, "tmp_linear_yield", CLOSURE_MODULE, "tmp_linear_yield",
                    CLOSURES.remove) as found:
        assert "granflow.rheology.tmp_linear_yield" in found
        assert "tmp_linear_yield" in CLOSURES.names()
        closure = make_closure("tmp_linear_yield")
        assert closure.name == "tmp_linear_yield" and closure.reference is False

        # the registry-wide checks of test_conditions.test_non_reference_closures_pass_c1_and_equilibrium
        assert_c1_and_equilibrium(closure)
        phi = np.array([0.45, 0.55, 0.59])[:, None]
        I = closure.I_eq(phi) * np.array([0.05, 0.7, 1.3, 20.0])[None, :]
        f = closure.f(phi, 1e3, I)
        # f against the formula written here, and the stiff-safe divergence law at rest (test_closures)
        ieq = closure.I_eq(phi)
        assert np.allclose(f, A + B * I / 4 - ieq * (A + B * ieq / 4) / I, rtol=1e-12, atol=1e-14)
        assert np.all(np.isfinite(closure.div_rate(phi, 1e3, 0.0)))
        assert np.all(closure.div_rate(phi, 1e3, 0.0) <= 0)
        d = check(closure).to_dict()  # test_conditions.test_to_dict_round_trips_and_table_lists_conditions
        assert json.loads(json.dumps(d, allow_nan=False)) == d
        assert d["closure"] == "tmp_linear_yield" and d["parameters"]["a"] == A
        # the same law as power_law with Z = A + B I: the same values and the same verdicts
        twin = make_closure("power_law", exponents=(0.0, 1.0), coefficients=(A, B))
        for fn in ("Z", "dZ_dI"):
            assert np.allclose(getattr(closure, fn)(phi, I), getattr(twin, fn)(phi, I), rtol=1e-13)
        for fn in ("f", "df_dI", "df_dphi"):
            assert np.allclose(getattr(closure, fn)(phi, 1e3, I), getattr(twin, fn)(phi, 1e3, I),
                               rtol=1e-12, atol=1e-14)
        twin_d = check(twin).to_dict()["conditions"]
        assert set(d["conditions"]) == set(twin_d)
        assert {k: c["pass"] for k, c in d["conditions"].items()} == {k: c["pass"] for k, c in twin_d.items()}

        # a static layer with the new closure: the solver finds the lithostatic pressure, no motion
        g = Grid(nx=6, nz=10, Lx=0.06, Lz=0.1)
        model = Model(g, make_closure("tmp_linear_yield", material=dict(d=70e-6, phi_max=0.6)))
        _, Zc = g.cell_coords()
        state = State.at_rest(g, np.where(Zc < 0.07, 0.6, 0.0))
        for _ in range(3):
            report = model.advance(state, 1e-3)
            assert report.status is StepStatus.OK, report.message
        assert np.all(np.isfinite(state.p)) and state.p.max() > 0
        assert np.max(np.abs(state.vel)) <= 1e-3 * model.eps * 0.07
    assert "tmp_linear_yield" not in CLOSURES
    assert "granflow.rheology.tmp_linear_yield" not in rheology_pkg.discover()


# ---- a new case is one file ----------------------------------------------------------------------
def test_case_in_a_new_file_is_discovered_validated_and_set_up(tmp_path):
    with extra_part(cases_pkg, tmp_path, "tmp_layer", CASE_MODULE, "tmp_layer",
                    CASES.unregister) as found:
        assert "granflow.cases.tmp_layer" in found
        assert "tmp_layer" in CASES.names()
        config = validate({"case": {"name": "tmp_layer"}, "setup": {"H": 0.02},
                           "grid": {"nx": 8, "nz": 6, "Lx": 0.08, "Lz": 0.06}})
        assert config.setup.H == 0.02
        sim = CASES.get("tmp_layer").setup(config)
        assert sim.state.phi.max() == pytest.approx(config.material.phi_max)
    assert "tmp_layer" not in CASES


# ---- every module is a part module or infrastructure ---------------------------------------------
@pytest.mark.parametrize("package", [rheology_pkg, cases_pkg], ids=["rheology", "cases"])
def test_every_module_is_discovered_or_infrastructure(package):
    assert unaccounted(package) == []
    assert part_modules(package) <= set(package.discover())


HELPER_MODULE = '''
"""A helper that registers nothing and is not declared infrastructure."""
def helper():
    return 1
'''


@pytest.mark.parametrize("package", [rheology_pkg, cases_pkg], ids=["rheology", "cases"])
def test_a_module_neither_part_nor_infrastructure_is_reported(package, tmp_path):
    with extra_part(package, tmp_path, "tmp_helper", HELPER_MODULE, "tmp_helper", lambda name: None):
        assert unaccounted(package) == [f"{package.__name__}.tmp_helper: discovered but registers nothing"]
    assert unaccounted(package) == []
