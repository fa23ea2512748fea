"""The Picard loop's first iterate (``numerics.picard.predictor``, :func:`granflow.step.first_iterate`)
and the linearly implicit step it makes possible (``max_sweeps = 1``; docs/solver.md, "One solve
per step").

References are computed here, independently of the scheme under test: the same case iterated to
``picard.tol = 1e-8`` (the fixed point the one-solve step approximates), and the steady state of
the converged loop (itself within 1.2 % of Bagnold's profile, tests/integration/test_inclined_plane.py).
"""
from __future__ import annotations

import tomllib
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from granflow.cases import CASES
from granflow.config import CaseConfig
from granflow.model_options import PicardParams
from granflow.predictor import STARTUP_SWEEPS, minmod, sweep_cap
from granflow.step import first_iterate

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "inclined_layer_from_rest.toml"


def layer(stop_time: float, dt_max: float, nz: int = 13, **picard) -> np.ndarray:
    """Velocity at ``stop_time`` of the 25° layer released from rest (the example, ``nz`` cells)."""
    d = tomllib.loads(EXAMPLE.read_text())
    d["grid"].update(nz=nz)
    d["time"].update(stop_time=stop_time, dt_max=dt_max)
    d["numerics"] = {"picard": picard}
    sim = CASES.get("inclined_layer").setup(CaseConfig.from_dict(d))
    sim.run()
    return sim.state.vel.copy()


def test_first_iterate_extrapolates_the_last_steps_acceleration():
    vel, accel = np.array([1.0, -2.0, 0.5]), np.array([0.5, 4.0, -1.0])
    state = SimpleNamespace(vel=vel, accel=accel, accel_dt=0.5, accel_prev=None)
    model = SimpleNamespace(picard=PicardParams(predictor="extrapolated"))
    assert np.array_equal(first_iterate(model, state, 0.25), [1.125, -1.0, 0.25])
    # never further than the last step's own change: a 1 s step after a 0.5 s one goes 0.5 s
    assert np.array_equal(first_iterate(model, state, 1.0), [1.25, 0.0, 0.0])
    assert np.array_equal(first_iterate(model, SimpleNamespace(vel=vel, accel=accel, accel_dt=None, accel_prev=None),
                                        1.0), [1.5, 2.0, -0.5])
    assert np.array_equal(first_iterate(model, SimpleNamespace(vel=vel, accel=None, accel_dt=None, accel_prev=None),
                                        0.25), vel)
    previous = first_iterate(SimpleNamespace(picard=PicardParams(predictor="previous")), state, 0.25)
    assert np.array_equal(previous, vel) and previous is not vel  # a copy: the loop overwrites it


def test_first_iterate_limits_the_extrapolation_by_the_step_before():
    """minmod(a^n, a^(n-1)) per unknown: the smaller where both agree in sign, none where the
    acceleration flipped (a step-to-step oscillation is not extrapolated)."""
    vel = np.array([1.0, -2.0, 0.5, 0.0])
    state = SimpleNamespace(vel=vel, accel=np.array([0.5, 4.0, -1.0, 2.0]), accel_dt=0.5,
                            accel_prev=np.array([2.0, -4.0, -0.25, 0.0]))
    model = SimpleNamespace(picard=PicardParams(predictor="extrapolated"))
    assert np.array_equal(first_iterate(model, state, 0.5), [1.25, -2.0, 0.375, 0.0])


def test_minmod_is_the_signed_minimum_or_zero():
    """:func:`granflow.predictor.minmod` (a median of three) against its definition,
    ``sign(a) min(|a|, |b|)`` where ``a b > 0`` else 0, on random values with zeros, equal
    magnitudes and both signs."""
    rng = np.random.default_rng(3)
    a, b = rng.standard_normal(4000), rng.standard_normal(4000)
    a[::7], b[::11], b[::13] = 0.0, 0.0, -a[::13]
    b[::17] = a[::17]
    expected = np.where(a * b > 0, np.sign(a) * np.minimum(np.abs(a), np.abs(b)), 0.0)
    assert np.array_equal(minmod(a, b), expected)


def test_one_solve_per_step_iterates_the_step_without_an_acceleration():
    """``sweep_cap``: a one-solve step with the extrapolated predictor and no ``a^n`` (the first
    of a run, a restart without ``state.accel``) gets the loop (STARTUP_SWEEPS, to picard.tol);
    every other step, and the iterated loop always, its ``max_sweeps``."""
    no_accel, accel = SimpleNamespace(accel=None), SimpleNamespace(accel=np.zeros(3))
    one = SimpleNamespace(picard=PicardParams(max_sweeps=1, predictor="extrapolated"))
    assert sweep_cap(one, no_accel) == STARTUP_SWEEPS > 10 and sweep_cap(one, accel) == 1
    for picard in (PicardParams(max_sweeps=1, predictor="previous"), PicardParams(max_sweeps=10, predictor="previous"),
                   PicardParams(max_sweeps=2, predictor="extrapolated")):
        for state in (no_accel, accel):
            assert sweep_cap(SimpleNamespace(picard=picard), state) == picard.max_sweeps


def test_predictor_is_validated():
    with pytest.raises(ValueError, match="predictor"):
        PicardParams(predictor="quadratic")


def test_one_solve_per_step_reaches_the_converged_steady_layer():
    """A steady state is a fixed point of the lagged linearisation: one solve per step ends where
    the iterated loop ends (here within 1e-4; measured 0.43805 m/s both at 26 cells)."""
    converged = layer(12.0, 0.05)
    one_solve = layer(12.0, 0.05, max_sweeps=1, predictor="extrapolated")
    scale = np.abs(converged).max()
    assert scale > 0.3  # flowing (u_s ~ 0.44 m/s)
    assert np.abs(one_solve - converged).max() <= 1e-4 * scale


def test_linearisation_error_shrinks_with_dt_and_with_the_extrapolation():
    """While the layer accelerates from rest (t = 1 s, of a ~2 s relaxation), one solve per step
    against the loop iterated to tol 1e-8: the lagged coefficients' error falls with dt, and the
    extrapolated first iterate makes it several times smaller (measured at t = 1 s: 0.58 / 0.24
    relative with u^n, 0.078 / 0.032 extrapolated, at dt = 0.02 / 0.01 s)."""
    errors = {}
    for dt in (0.02, 0.01):
        ref = layer(1.0, dt, max_sweeps=300, tol=1e-8)
        scale = np.abs(ref).max()
        for predictor in ("previous", "extrapolated"):
            u = layer(1.0, dt, max_sweeps=1, predictor=predictor)
            errors[predictor, dt] = np.abs(u - ref).max() / scale
    for dt in (0.02, 0.01):
        assert errors["extrapolated", dt] < errors["previous", dt] / 4, errors
    for predictor in ("previous", "extrapolated"):
        assert errors[predictor, 0.01] < errors[predictor, 0.02] / 1.8, errors


def chute_drift(nz: int, cfl: float | None = None, t_end: float = 20.0) -> float:
    """u_s drift (peak-to-peak over the last 2 s / u_s) of the 25° fluidised chute from rest
    (beta = 0.15, the example with ``nz`` cells), one solve per step, extrapolated."""
    from granflow.cases.inclined_layer import surface_velocity

    d = tomllib.loads(EXAMPLE.read_text())
    d["setup"].update(beta=0.15)
    d["gas"] = {"law": "linear"}
    d["grid"].update(nz=nz)
    if cfl is not None:
        d["time"].update(cfl=cfl)
    d["numerics"] = {"picard": {"max_sweeps": 1, "predictor": "extrapolated"}}
    sim = CASES.get("inclined_layer").setup(CaseConfig.from_dict(d))
    record = []
    while sim.state.t < t_end - 1e-9:
        sim.step()
        record.append((sim.state.t, surface_velocity(sim)))
    t, u = np.array(record).T
    assert u[-1] > 1.0  # flowing (Bagnold u_s ~ 1.66 m/s)
    return float(np.ptp(u[t >= t_end - 2.0]) / u[-1])


def test_one_solve_per_step_settles_the_fluidised_chute():
    """validation/inclined_plane's 25° fluidised chute from rest (beta = 0.15, 20 cells): the steps
    alternate 0.044 / 0.006 s to land on the 0.05 s records; extrapolating the short step's change
    over the long one (7x) kept the surface cells cycling and u_s drifting by 3.5e-3 over the last
    2 s. With the extrapolation capped at the last step's length it is steady like the iterated
    loop (bound 6.1e-4, the largest drift of the stored from-rest table before session 21; measured 4e-6)."""
    assert chute_drift(nz=26) <= 6.1e-4


def test_one_solve_per_step_keeps_the_40_cell_chute_steady_at_cfl_0_4():
    """The same chute on 40 cells over h0 with time.cfl = 0.4 (dt ~ 0.047 s): a mode that flips
    sign each step was extrapolated to ~3x its amplitude, drift 7.8e-3 over the last 2 s (the
    iterated loop and one solve from u^n: ~1e-6); the minmod limiter of the extrapolation
    (granflow.predictor) measured 1.1e-6."""
    assert chute_drift(nz=52, cfl=0.4) <= 6.1e-4


def test_a_one_solve_run_neither_warns_nor_says_not_converged(tmp_path, capsys):
    import json

    from granflow.cli import main

    out = tmp_path / "run"
    args = ["run", str(EXAMPLE), "--out", str(out), "--set", "time.stop_time=0.5", "--set", "output.figures=false",
            "--set", "numerics.picard.max_sweeps=1", "--set", 'numerics.picard.predictor="extrapolated"']
    assert main(args) == 0
    printed = "".join(capsys.readouterr())
    summary = json.loads((out / "summary.json").read_text())
    assert summary["picard"]["max_sweeps"] == 1 and summary["picard"]["not_converged_steps"] > 0  # counted
    assert not [w for w in summary["warnings"] if "Picard" in w]
    assert "one solve per step" in printed and "not converged" not in printed


def test_fail_tol_judges_the_loop_not_the_one_solve_step():
    """With one solve the 'increment' is the step's change from the first iterate (0.3-0.5 in the
    first steps from rest): fail_tol = 0.1 must not reject it; iterated, the same fail_tol still
    fails a step that stops unconverged at the cap."""
    from granflow.simulation import StepFailure

    assert np.abs(layer(0.5, 0.05, max_sweeps=1, predictor="extrapolated", fail_tol=0.1)).max() > 0.0
    with pytest.raises(StepFailure):
        layer(0.5, 0.05, max_sweeps=1 + 1, tol=1e-12, fail_tol=1e-9)
