"""Shared check of a compiled (Numba) kernel inside whole model steps: the same short run with the
kernel and with its NumPy reference forced gives the same fields, bit for bit (used by
tests/unit/test_material_kernel.py and test_gravity_kernel.py)."""
from __future__ import annotations

from types import ModuleType

import numpy as np


def lagree_collapse(stop_time: float, n: int = 24):
    """The ``lagree_column`` case on n x n cells to ``stop_time`` (a Simulation, not run)."""
    from granflow.cases import CASES
    from granflow.config import CaseConfig

    cfg = CaseConfig.from_dict({"case": {"name": "lagree_column"}, "grid": {"nx": n, "nz": n},
                                "time": {"stop_time": stop_time, "dt_max": 0.01},
                                "output": {"figures": False}})
    return CASES.get("lagree_column").setup(cfg)


def kernel_and_reference_runs(monkeypatch, module: ModuleType, compiled: str, stop_time: float = 0.15):
    """``(run with the kernel, run with NumPy forced, kernel calls of the first run)``: ``module``'s
    function ``compiled`` is counted, then ``module.kernel_available`` is forced False; asserts that
    the forced run did not call the kernel, that both took the same steps and that phi, vel, p
    and c agree bit for bit."""
    calls: list[int] = []
    kernel = getattr(module, compiled)
    monkeypatch.setattr(module, compiled, lambda *a: calls.append(1) or kernel(*a))
    fast = lagree_collapse(stop_time)
    fast.run()
    n_calls = len(calls)
    monkeypatch.setattr(module, "kernel_available", lambda: False)
    ref = lagree_collapse(stop_time)
    ref.run()
    assert len(calls) == n_calls  # the forced run did not use the kernel
    assert len(fast.reports) == len(ref.reports)
    for name in ("phi", "vel", "p", "c"):
        assert np.array_equal(getattr(fast.state, name), getattr(ref.state, name)), name
    return fast, ref, n_calls
