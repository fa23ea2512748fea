"""Barker et al. (2015) criterion and window (granflow.theory.barker), cross-checked against an
independent SymPy evaluation and against the leading-order dispersion relation of the
incompressible closure (granflow.theory.dispersion).

Tolerances: criterion values 1e-12 absolute; window ends one grid step (0.01 %) of a dense scan;
growth signs with a margin of 1e-9 of eta/(phi rho_s).
"""
from __future__ import annotations

import json

import numpy as np
import pytest
import sympy as sp

from granflow.rheology import make_closure
from granflow.theory.barker import (
    barker_criterion,
    barker_ill_posed,
    barker_window,
)
from granflow.theory.dispersion import leading_order_max_growth

MU1 = float(np.tan(np.radians(21.0)))
MU2 = float(np.tan(np.radians(33.0)))
I0 = 0.3
P = 1e3  # Pa


def _sympy_criterion(mu1, mu2, i0):
    """4 nu^2 - 4 nu + mu^2 (1 - nu/2)^2 from mu(I) = mu1 + (mu2 - mu1)/(1 + I0/I), by SymPy."""
    I = sp.Symbol("I", positive=True)
    mu = mu1 + (mu2 - mu1) / (1 + i0 / I)
    nu = I * sp.diff(mu, I) / mu
    crit = 4 * nu**2 - 4 * nu + mu**2 * (1 - nu / 2) ** 2
    return sp.lambdify(I, crit, "numpy")


def test_criterion_matches_sympy():
    I = np.logspace(-6, 3, 50)
    expected = _sympy_criterion(MU1, MU2, I0)(I)
    np.testing.assert_allclose(barker_criterion(I, MU1, MU2, I0), expected, rtol=1e-12, atol=1e-14)
    # limits: nu -> 0 at both ends, so the criterion tends to mu1^2 and mu2^2
    assert barker_criterion(1e-14, MU1, MU2, I0) == pytest.approx(MU1**2, rel=1e-9)
    assert barker_criterion(1e14, MU1, MU2, I0) == pytest.approx(MU2**2, rel=1e-9)


@pytest.mark.parametrize("c_I", [2.0, 1.0])
def test_window_ends_are_roots_and_agree_with_dense_scan(c_I):
    w = barker_window(MU1, MU2, I0, c_I=c_I)
    assert w.exists and w.exact
    assert abs(barker_criterion(w.I_low, MU1, MU2, I0)) < 1e-12
    assert abs(barker_criterion(w.I_high, MU1, MU2, I0)) < 1e-12
    # independent dense scan with the SymPy criterion (step 1e-4 in log10 I)
    I = np.logspace(-6, 4, 100_001)
    neg = I[_sympy_criterion(MU1, MU2, I0)(I) < 0]
    step = 10**1e-4
    assert neg[0] / step <= w.I_low <= neg[0]
    assert neg[-1] <= w.I_high <= neg[-1] * step
    # negative strictly inside, positive outside
    assert barker_criterion(np.sqrt(w.I_low * w.I_high), MU1, MU2, I0) < 0
    assert barker_criterion(0.99 * w.I_low, MU1, MU2, I0) > 0
    assert barker_criterion(1.01 * w.I_high, MU1, MU2, I0) > 0


def test_window_conventions():
    lit = barker_window(MU1, MU2, I0, c_I=2.0)
    paper = barker_window(MU1, MU2, I0, c_I=1.0)
    # c_I = 2: the closure's I is the literature I
    assert lit.I_low_literature == lit.I_low and lit.I_high_literature == lit.I_high
    # the criterion depends on I/I0 only: same numbers in the closure's own I ...
    assert paper.I_low == pytest.approx(lit.I_low, rel=1e-12)
    assert paper.I_high == pytest.approx(lit.I_high, rel=1e-12)
    # ... and, in literature I, the paper's "I0 = 0.3" is a literature I0 of 0.6 (I_lit = 2 I_paper)
    doubled = barker_window(MU1, MU2, 2 * I0, c_I=2.0)
    assert paper.I_low_literature == pytest.approx(doubled.I_low, rel=1e-10)
    assert paper.I_high_literature == pytest.approx(doubled.I_high, rel=1e-10)
    assert paper.I_low_literature == pytest.approx(2 * paper.I_low, rel=1e-14)
    json.dumps(lit.to_dict())
    json.dumps(paper.to_dict())


def test_no_window():
    w = barker_window(0.9, 0.95, I0)  # mu ~ 0.9: criterion > 0 everywhere
    assert not w.exists
    assert w.I_low is None and w.I_high is None and w.I_low_literature is None
    d = w.to_dict()
    assert d["exists"] is False
    json.dumps(d)
    I = np.logspace(-8, 6, 2001)
    assert np.all(_sympy_criterion(0.9, 0.95, I0)(I) > 0)


@pytest.mark.parametrize("c_I", [2.0, 1.0])
def test_incompressible_leading_order_matches_window(c_I):
    """Item 2 cross-checks item 1: Lambda_max > 0 outside the window, < 0 inside."""
    w = barker_window(MU1, MU2, I0, c_I=c_I)
    c = make_closure("incompressible", material={"c_I": c_I}, mu1=MU1, mu2=MU2, I0=I0)
    phi = 0.58
    outside = [0.1 * w.I_low, 0.5 * w.I_low, 0.97 * w.I_low, 1.03 * w.I_high, 2 * w.I_high, 10 * w.I_high]
    inside = [1.03 * w.I_low, np.sqrt(w.I_low * w.I_high), 0.97 * w.I_high]
    for I in outside:
        r = leading_order_max_growth(c, phi, P, I, gas="none", n_theta=180)
        assert r.growth > 1e-9 * r.scale, I
    for I in inside:
        r = leading_order_max_growth(c, phi, P, I, gas="none", n_theta=180)
        assert r.growth < -1e-9 * r.scale, I


def test_barker_proviso_optimal_direction():
    """Barker's expression is g at the vertex s* = b/(2(1 - nu)); where s* > 1 it can be
    positive while the flow is well posed. mu1 << mu2 gives nu -> 1 at small I."""
    mu1, mu2 = 1e-4, 50.0
    c = make_closure("incompressible", mu1=mu1, mu2=mu2, I0=I0)
    I_false_alarm = [3e-3, 5e-3, 9e-3]      # criterion > 0, exact test: well posed
    I_pole = [2e-2, 3e-2]                    # b = mu(1 - nu/2) > 1: pole, ill posed
    for I in I_false_alarm:
        assert barker_criterion(I, mu1, mu2, I0) > 0
        assert not barker_ill_posed(I, mu1, mu2, I0)
        r = leading_order_max_growth(c, 0.58, P, I, gas="none", n_theta=180)
        assert r.growth < -1e-9 * r.scale
    for I in I_pole:
        assert barker_ill_posed(I, mu1, mu2, I0)
        r = leading_order_max_growth(c, 0.58, P, I, gas="none", n_theta=180)
        assert r.growth > 1e-9 * r.scale
    assert not barker_window(mu1, mu2, I0).exact
    # for the glass-bead parameters the two tests agree everywhere
    I = np.logspace(-8, 4, 2001)
    np.testing.assert_array_equal(barker_ill_posed(I, MU1, MU2, I0), barker_criterion(I, MU1, MU2, I0) > 0)
