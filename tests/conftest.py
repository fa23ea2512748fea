"""Shared test material: the closure cases and their INDEPENDENT SymPy references.

Every closure registered in ``CLOSURES`` is tested: a test that asks for the ``closure_case``
fixture is parametrised over :data:`CLOSURE_CASES`, built by looping over ``CLOSURES.names()``.
Closures listed in :data:`PARAMETER_SETS` get those parameter sets; any other (new) closure gets
its default parameters and, until someone writes its reference in :data:`REFERENCES`, the
reference-based tests fail with a message saying so (the generic property tests still run).

The references are written from the paper (Section 6, eqs f-DP, mu(I), F-mu(I), f-general, Table 1,
Z1, f1, psi, eq:86, eq:87, psi:mu(I), roux_radjai) and MODEL.md §3, never by calling granflow code:
they only read the *input* parameters (delta_deg, mu1, ...) and the material's inputs.
They are evaluated with mpmath at 40 significant digits, so that comparisons with the float64
library measure the library's error only.
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

# The tests are in tiers (tests/unit, tests/integration, tests/validation_smoke); the shared helpers
# (_scripts, _closure_checks, _figure_checks) stay here, importable from every tier.
TESTS = Path(__file__).resolve().parent
if str(TESTS) not in sys.path:
    sys.path.insert(0, str(TESTS))
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cache, cached_property
from typing import Any

import mpmath
import numpy as np
import pytest
import sympy as sp

from granflow import Material
from granflow.rheology import CLOSURES, make_closure

#: Symbols of the references: packing fraction, granular pressure [Pa], inertial number.
PHI, P, I = sp.symbols("phi p I", positive=True)
_J = sp.Symbol("J", positive=True)

#: Working precision (decimal digits) of the mpmath reference evaluations.
MP_DPS = 40

#: Material used for the reference comparisons: deliberately not the defaults (catches a
#: hard-coded 0.6 / 0.2 / 80 um / 2500 / c_I).
TEST_MATERIAL = dict(d=1.0e-4, rho_s=2600.0, phi_max=0.61, delta_phi=0.22, c_I=2.0)

TAN21 = math.tan(math.radians(21.0))
TAN33 = math.tan(math.radians(33.0))


class AtPZero:
    """What 2|S| f tends to as p -> 0 at fixed |S| > 0 (I -> inf), written by hand from the formula."""

    FINITE = "finite"
    PLUS_INF = "+inf"
    MINUS_INF = "-inf"


# ---------------------------------------------------------------------------------------------
# Reference formulas (SymPy), written from the paper
# ---------------------------------------------------------------------------------------------
def num(x: float) -> sp.Rational:
    """The exact value of a float parameter, so that SymPy manipulations add no rounding."""
    return sp.Rational(x)


def ieq_linear(mat: dict[str, float]) -> sp.Expr:
    """I_eq(phi) = (phi_max - phi)/delta_phi (paper eq. I(phi))."""
    return (num(mat["phi_max"]) - PHI) / num(mat["delta_phi"])


def mu_expr(mu1: float, mu2: float, I0: float, x: sp.Expr = I) -> sp.Expr:
    """mu(I) = mu1 + (mu2 - mu1)/(1 + I0/I) (paper eq. mu(I))."""
    return num(mu1) + (num(mu2) - num(mu1)) / (1 + num(I0) / x)


def F_expr(mu1: float, mu2: float, I0: float, x: sp.Expr = I) -> sp.Expr:
    """F(I) = mu2 + (mu2 - mu1)/2 (1/(1+I/I0) - 3 ln(1+I/I0)/(I/I0)) (paper eq. F-mu(I))."""
    y = x / num(I0)
    return num(mu2) + (num(mu2) - num(mu1)) / 2 * (1 / (1 + y) - 3 * sp.log(1 + y) / y)


def G_expr(mu1: float, mu2: float, I0: float, x: sp.Expr = I) -> sp.Expr:
    """Robinson's G(I) (paper eq. psi:mu(I))."""
    y = x / num(I0)
    return 2 * num(mu1) / 3 * sp.log(y) + (num(mu2) - num(mu1)) / 3 * (
        1 / (1 + y) + 2 * sp.log(1 + y)
    )


def sin_cos_deg(delta_deg: float) -> tuple[sp.Expr, sp.Expr]:
    a = num(delta_deg) * sp.pi / 180
    return sp.sin(a), sp.cos(a)


def f_general(Z: sp.Expr, Ieq: sp.Expr) -> sp.Expr:
    """f = W(I) - I_eq W(I_eq)/I, W = (3/(2I)) int_0^I Z dJ - Z/2 (paper eq. f-general), by SymPy
    integration of the given Z (lower bound 0, valid for the integrable Z used here)."""
    W = sp.Rational(3, 2) * sp.integrate(Z.subs(I, _J), (_J, 0, I)) / I - Z / 2
    return W - Ieq * W.subs(I, Ieq) / I


def ref_drucker_prager(params, mat):
    s, _ = sin_cos_deg(params["delta_deg"])
    return s, s * (1 - ieq_linear(mat) / I)  # eq. f-DP


def ref_drucker_prager_dilatancy(params, mat):
    s, c = sin_cos_deg(params["delta_deg"])
    beta = 2 * (1 - c) / (2 + c)
    psi = s / (1 - c) * (1 - (ieq_linear(mat) / I) ** beta)  # eq. psi
    return s + c * psi, psi  # eqs. Z1, f1


def ref_mu_i(params, mat):
    m = (params["mu1"], params["mu2"], params["I0"])
    Ieq = ieq_linear(mat)
    return mu_expr(*m), F_expr(*m) - Ieq / I * F_expr(*m, x=Ieq)  # eq. f-mu(I) / syst4mu(I)


def ref_mu_i_dilatancy(params, mat):
    m = (params["mu1"], params["mu2"], params["I0"])
    psi = G_expr(*m) - G_expr(*m, x=ieq_linear(mat))  # eq. psi:mu(I)
    return mu_expr(*m) + psi, psi  # eqs. eq:86, eq:87


def ref_power_law(params, mat):
    Z = sum(
        num(c) * I ** sp.nsimplify(n) for n, c in zip(params["exponents"], params["coefficients"])
    )
    return Z, f_general(Z, ieq_linear(mat))


def _yield(params):
    if params["yield_law"] == "mu_i":
        return mu_expr(params["mu1"], params["mu2"], params["I0"])
    return sin_cos_deg(params["delta_deg"])[0]


def ref_roux_radjai(params, mat):
    phi_eq = num(mat["phi_max"]) - num(mat["delta_phi"]) * I  # eq. phi(I)
    return _yield(params), num(params["a"]) * (PHI - phi_eq)  # eq. roux_radjai


def ref_incompressible(params, mat):
    return _yield(params), sp.Integer(0)


# The generic closure: one hand-written reference per expression tested.
MU_I_EXPRESSION = "0.38 + 0.26*I/(I + 0.3)"  # mu(I) with mu1 = 0.38, mu2 = 0.64, I0 = 0.3
PHI_EXPRESSION = "0.3 + 0.5*(0.6-phi) + 0.2*I"
SQRT_EXPRESSION = "0.4 + 0.2*sqrt(I)"


def _generic_mu(mat):
    return ref_mu_i(dict(mu1=0.38, mu2=0.64, I0=0.3), mat)


def _generic_phi(mat):
    # Table 1 rows n = 0 and n = 1 combined with phi-dependent coefficients (paper §6.3).
    Ieq = ieq_linear(mat)
    a0 = num(0.3) + num(0.5) * (num(0.6) - PHI)
    Z = a0 + num(0.2) * I
    return Z, a0 * (1 - Ieq / I) + num(0.2) / 4 * (I - Ieq**2 / I)


def _generic_sqrt(mat):
    # Table 1 row n = 1/2: coefficient (2 - n)/(2(n + 1)) = 1/2.
    Ieq = ieq_linear(mat)
    Z = num(0.4) + num(0.2) * sp.sqrt(I)
    return Z, num(0.4) * (1 - Ieq / I) + num(0.2) / 2 * (sp.sqrt(I) - Ieq ** sp.Rational(3, 2) / I)


GENERIC_REFERENCES: dict[str, Callable] = {
    MU_I_EXPRESSION: _generic_mu,
    PHI_EXPRESSION: _generic_phi,
    SQRT_EXPRESSION: _generic_sqrt,
}


def ref_generic(params, mat):
    return GENERIC_REFERENCES[params["expression"]](mat)


REFERENCES: dict[str, Callable] = {
    "drucker_prager": ref_drucker_prager,
    "drucker_prager_dilatancy": ref_drucker_prager_dilatancy,
    "mu_i": ref_mu_i,
    "mu_i_dilatancy": ref_mu_i_dilatancy,
    "power_law": ref_power_law,
    "generic": ref_generic,
    "roux_radjai": ref_roux_radjai,
    "incompressible": ref_incompressible,
}

_MU_A = dict(mu1=0.38, mu2=0.64, I0=0.3)
_MU_B = dict(mu1=TAN21, mu2=TAN33, I0=0.3)
_RR_MU = dict(yield_law="mu_i", mu1=0.32, mu2=0.6, I0=0.4, delta_deg=25.0)
_RR_DP = dict(yield_law="drucker_prager", mu1=TAN21, mu2=TAN33, I0=0.3, delta_deg=28.0)

#: (parameters, behaviour of 2|S|f as p -> 0) for each closure name.
PARAMETER_SETS: dict[str, list[tuple[dict[str, Any], str]]] = {
    "drucker_prager": [(dict(delta_deg=25.0), AtPZero.FINITE), (dict(delta_deg=30.0), AtPZero.FINITE)],
    "drucker_prager_dilatancy": [(dict(delta_deg=30.0), AtPZero.FINITE), (dict(delta_deg=22.0), AtPZero.FINITE)],
    "mu_i": [(_MU_A, AtPZero.FINITE), (_MU_B, AtPZero.FINITE)],
    # psi = G(I) - G(I_eq) grows like ln I.
    "mu_i_dilatancy": [(_MU_A, AtPZero.PLUS_INF), (_MU_B, AtPZero.PLUS_INF)],
    "power_law": [
        (dict(exponents=(0.0, 1.0), coefficients=(0.4, 0.2)), AtPZero.PLUS_INF),
        # Table 1 coefficient (2-3)/8 < 0: f -> -inf (genuinely unbounded, with a minus sign).
        (dict(exponents=(3.0,), coefficients=(0.1,)), AtPZero.MINUS_INF),
        (dict(exponents=(0.5, 2.0), coefficients=(0.3, 0.05)), AtPZero.PLUS_INF),
        # f = 0.5/4 (I - ..) - 0.1/8 (I^3 - ..): the I^3 term wins, -inf (not inf - inf = NaN).
        (dict(exponents=(1.0, 3.0), coefficients=(0.5, 0.1)), AtPZero.MINUS_INF),
    ],
    "generic": [
        (dict(expression=MU_I_EXPRESSION), AtPZero.FINITE),
        (dict(expression=PHI_EXPRESSION), AtPZero.PLUS_INF),
        (dict(expression=SQRT_EXPRESSION), AtPZero.PLUS_INF),
    ],
    # phi_eq(I) -> -inf for the linear law, so f = a(phi - phi_eq) -> +inf.
    "roux_radjai": [(dict(_RR_MU, a=1.0), AtPZero.PLUS_INF), (dict(_RR_DP, a=2.0), AtPZero.PLUS_INF)],
    "incompressible": [(dict(_RR_MU), AtPZero.FINITE), (dict(_RR_DP), AtPZero.FINITE)],
}


# ---------------------------------------------------------------------------------------------
# mpmath evaluation
# ---------------------------------------------------------------------------------------------
@cache
def _mp_function(expr: sp.Expr):
    return sp.lambdify((PHI, P, I), expr, modules="mpmath")


def mp_eval(expr: sp.Expr, phi, p, Ival, dps: int = MP_DPS) -> np.ndarray:
    """Evaluate a SymPy expression of (phi, p, I) with mpmath at ``dps`` digits, elementwise.

    ``Ival`` may hold Python strings (e.g. "1e1000") to reach beyond float range."""
    fn = _mp_function(expr)
    phi, p, Ival = np.broadcast_arrays(np.asarray(phi, dtype=float), np.asarray(p, dtype=float),
                                       np.asarray(Ival, dtype=object))
    out = np.empty(phi.shape, dtype=float)
    with mpmath.workdps(dps):
        for idx in np.ndindex(phi.shape):
            v = fn(mpmath.mpf(float(phi[idx])), mpmath.mpf(float(p[idx])), mpmath.mpf(Ival[idx]))
            out[idx] = float(mpmath.re(v)) if isinstance(v, mpmath.mpc) else float(v)
    return out


@dataclass
class ClosureCase:
    """One closure with one parameter set, and its reference (Z, f) for the linear law."""

    name: str
    params: dict[str, Any]
    at_p_zero: str
    material: dict[str, float] = field(default_factory=lambda: dict(TEST_MATERIAL))

    @property
    def id(self) -> str:
        def fmt(v):
            return f"{v:.4g}" if isinstance(v, float) else str(v)

        short = ",".join(f"{k}={fmt(v)}" for k, v in self.params.items())
        return f"{self.name}[{short}]" if short else self.name

    @property
    def is_reference(self) -> bool:
        """True for the closures kept only for comparison (class attribute ``reference``)."""
        return CLOSURES.get(self.name).reference

    _built: dict = field(default_factory=dict, repr=False, compare=False)

    def build(self, equilibrium: str = "linear", eta_visc: float = 0.0, **material_overrides):
        """The closure with this equilibrium law (memoised: the generic closure takes ~0.3 s)."""
        key = (equilibrium, eta_visc, tuple(sorted(material_overrides.items())))
        if key not in self._built:
            self._built[key] = make_closure(self.name, material={**self.material, **material_overrides},
                                            equilibrium=equilibrium, eta_visc=eta_visc, **self.params)
        return self._built[key]

    @cached_property
    def closure(self):
        return self.build()

    @cached_property
    def ref(self) -> tuple[sp.Expr, sp.Expr]:
        """(Z, f) written from the paper for the linear equilibrium law."""
        if self.name not in REFERENCES:
            pytest.fail(f"closure {self.name!r} has no independent reference in tests/conftest.py "
                        "REFERENCES; write its (Z, f) from the paper")
        return REFERENCES[self.name](self.params, self.material)


def _cases() -> list[ClosureCase]:
    cases = []
    for name in CLOSURES.names():
        for params, at_p0 in PARAMETER_SETS.get(name, [({}, AtPZero.FINITE)]):
            cases.append(ClosureCase(name, dict(params), at_p0))
    return cases


CLOSURE_CASES = _cases()


def pytest_generate_tests(metafunc):
    if "closure_case" in metafunc.fixturenames:
        metafunc.parametrize("closure_case", CLOSURE_CASES, ids=[c.id for c in CLOSURE_CASES])


@pytest.fixture
def material() -> Material:
    return Material(**TEST_MATERIAL)
