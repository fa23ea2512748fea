"""The linearised dilatancy row ``div u + C p = b`` of :meth:`granflow.model.Model.coefficients`
is the tangent in p of the closure's divergence law (paper eq. syst4b, ``Closure.div_rate``) at
the iterate p_k, for every registered closure: its value at p_k is the law's, and its slope ``-C``
is the law's derivative, taken here by central finite differences of ``div_rate`` (an independent
evaluation: the closed-form law, not the split into A and G the row is built from). With dt = 0
the AP factor is 1, so the row is the law itself.

Why the tangent (docs/solver.md, "One solve per step"): the secant ``G sqrt(p) ~ G p/sqrt(p_k)``
used until 2026-12-06 is twice as stiff, and its lag grew a period-2 mode of the steady fluidised
chute for dt >= 0.045 s (the second test here).

Tolerances: |S| >= 2 s^-1 >> eps = 5e-3 s^-1 and p >= 200 Pa >> delta_p, so the regularisations
move the row by < 1e-4 relative; finite-difference step 1e-4 p (truncation ~1e-8).
"""
from __future__ import annotations

import numpy as np
import pytest

from granflow.grid import Grid
from granflow.model import Model

PHI = np.array([0.55, 0.58, 0.59, 0.55, 0.58, 0.59])
P_K = np.array([200.0, 2.0e3, 2.0e4, 5.0e2, 5.0e3, 1.0e4])
S = np.array([2.0, 20.0, 5.0, 50.0, 3.0, 10.0])


def model_of(closure_case) -> Model:
    """A small model of the closure (the row's coefficients do not depend on the grid)."""
    model = Model(Grid(nx=3, nz=2, Lx=0.03, Lz=0.02), closure_case.closure)
    if model.closure.isochoric:
        pytest.skip("isochoric closure: no dilatancy row (div u = 0)")
    return model


DENSE = np.ones(PHI.size, dtype=bool)


def test_row_is_the_tangent_of_the_divergence_law(closure_case):
    closure, model = closure_case.closure, model_of(closure_case)
    coef = model.coefficients(PHI, P_K, S, 0.0, DENSE)
    row_at_pk = coef.b - coef.C * P_K
    law = np.asarray(closure.div_rate(PHI, P_K, S), dtype=float)
    h = 1e-4 * P_K
    slope = (np.asarray(closure.div_rate(PHI, P_K + h, S)) - np.asarray(closure.div_rate(PHI, P_K - h, S))) / (2 * h)
    scale = np.abs(law) + np.abs(slope * P_K)
    assert np.all(np.abs(row_at_pk - law) <= 1e-4 * scale), (row_at_pk, law)
    assert np.all(np.abs(-coef.C - slope) * P_K <= 1e-4 * scale), (-coef.C, slope)


def test_later_sweeps_take_the_secant(closure_case):
    """``tangent=False`` (a step's later sweeps): the same value at p_k, the compaction term's
    slope twice the tangent's, ``G/sqrt(p_k)`` against ``G/(2 sqrt(p_k))``."""
    closure, model = closure_case.closure, model_of(closure_case)
    tan = model.coefficients(PHI, P_K, S, 0.0, DENSE)
    sec = model.coefficients(PHI, P_K, S, 0.0, DENSE, tangent=False)
    scale = np.abs(tan.b) + np.abs(tan.C * P_K)
    assert np.all(np.abs((sec.b - sec.C * P_K) - (tan.b - tan.C * P_K)) <= 1e-12 * scale)
    half_G = np.asarray(closure.compaction_coefficient(PHI)) / (2 * np.sqrt(np.hypot(P_K, model.delta_p)))
    assert np.allclose(sec.C - tan.C, half_G, rtol=1e-12, atol=1e-300)


def test_fluidised_chute_is_steady_at_cfl_0_4():
    """The 25 deg fluidised chute (beta = 0.15, 20 cells over h0, from rest, the Picard loop) at
    time.cfl = 0.4 (dt = dt_max = 0.05 s), to t = 25 s: u_s drifts 3.6e-8 over the last 2 s with
    the tangent, 1.6e-3 with the secant (a mode growing 5.6x a second from t ~ 5 s; 4.3e-4 at
    t = 20 s); to 40 s the tangent's state equals the dt = 0.025 s run to 12 digits. Bound 1e-6
    (the tests' steadiness criterion is 1e-3), Bagnold within 1 %."""
    from _scripts import load_script

    inclined = load_script("validation/inclined_plane/run.py", "validation_inclined_plane_run")
    r = inclined.from_rest(20, 25.0, 0.15, t_end=25.0, cfl=0.4)
    assert r["drift"] < 1e-6 and abs(r["err_us"]) < 1e-2, r
