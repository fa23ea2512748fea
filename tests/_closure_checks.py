"""Checks every closure of the registry must pass, shared by tests/unit/test_conditions.py (looping over
the registry) and tests/unit/test_registry_discovery.py (a closure added at test time)."""
import numpy as np

from granflow.theory import conditions as cond
from granflow.theory.conditions import check


def assert_c1_and_equilibrium(closure) -> None:
    """C1 and the equilibrium conditions pass (granflow.theory), and an independent cross-check of
    the C1 verdict with central finite differences of Z and f only (not the closure's derivative
    methods; relative step 1e-5, tolerance 1e-6)."""
    rep = check(closure)
    c1 = rep.conditions["C1"]
    assert c1.passed and c1.worst_value < cond.C1_TOLERANCE  # relative residual, tol 1e-9
    assert rep.conditions["equilibrium"].passed
    assert rep.conditions["equilibrium"].extra["max_abs_f_at_eq"] < 1e-12
    assert rep.reference is False
    phi = np.array([0.45, 0.55, 0.59])[:, None]
    I = closure.I_eq(phi) * np.array([0.05, 0.7, 1.3, 20.0])[None, :]
    h = 1e-5 * I
    Z, f = closure.Z(phi, I), closure.f(phi, 1e3, I)
    dZ = (closure.Z(phi, I + h) - closure.Z(phi, I - h)) / (2 * h)
    df = (closure.f(phi, 1e3, I + h) - closure.f(phi, 1e3, I - h)) / (2 * h)
    res = Z - I * dZ / 2 - (f + I * df)
    scale = abs(Z) + abs(I * dZ) / 2 + abs(f) + abs(I * df)
    assert np.all(abs(res) <= 1e-6 * scale)
