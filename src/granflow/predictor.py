"""The Picard loop's first iterate (``numerics.picard.predictor``, :class:`granflow.model_options.
Predictor`; docs/solver.md, "One solve per step"): ``u^n``, or a limited linear extrapolation in
time from the last two steps' mean accelerations (:attr:`granflow.state.State.accel`,
``accel_prev``), which :meth:`granflow.model.Model.advance` stores with that predictor; and the
sweep cap of a step (:func:`sweep_cap`: one solve per step iterates the step that has no
acceleration to extrapolate).
"""
from __future__ import annotations

import numpy as np

from granflow.model_options import Predictor


def first_iterate(model, state, dt: float) -> np.ndarray:
    """The Picard loop's first velocity iterate [m s^-1] (:class:`granflow.model_options.Predictor`):
    ``u^n``, or ``u^n + min(dt, dt_(n-1)) minmod(a^n, a^(n-1))`` with the last two steps' mean
    accelerations ``a^n = state.accel``, ``a^(n-1) = state.accel_prev`` (a linear extrapolation
    in time, ``a^n`` alone at the second step, ``u^n`` at the first).

    - The cap ``min(dt, dt_(n-1))``: a short step (to land on an output time) followed by a long
      one extrapolated a jump of the surface cells 7x and kept the 25 deg fluidised chute of
      validation/inclined_plane from settling with one solve per step (u_s drift 3.5e-3 over
      2 s; capped 4e-6, as iterated).
    - The limiter (:func:`minmod`, per unknown): no extrapolation where the acceleration changed
      sign, the smaller of the two where it did not. An oscillation that flips sign each step
      (|lambda| ~ 0.8) is extrapolated to ``(2 - 1/lambda) ~ 3.2x`` its amplitude, and that kept
      the 40-cell fluidised chute at cfl 0.4 unsteady with one solve per step (drift 7.8e-3;
      limited 1.1e-6; docs/solver.md "One solve per step").
    """
    if model.picard.predictor == Predictor.EXTRAPOLATED and state.accel is not None:
        reach = dt if state.accel_dt is None else min(dt, state.accel_dt)
        a = state.accel if state.accel_prev is None else minmod(state.accel, state.accel_prev)
        return state.vel + reach * a
    return state.vel.copy()


STARTUP_SWEEPS = 50
"""Sweep cap of a one-solve step without ``a^n`` (:func:`sweep_cap`). The loop stops at
``picard.tol`` as ever; from rest the Coulomb base's secant converges at the rate
``mu_w / tan(theta)`` a sweep: the sliding block of tests/integration/test_wall_friction.py at 22 deg on
tan 15 deg takes 28 sweeps (18 at 15 deg on tan 8 deg), where the loop's default cap of 10
left it 2.3 % slow at t = 0.1 s."""


def sweep_cap(model, state) -> int:
    """The Picard loop's sweep cap for this step: ``picard.max_sweeps``, but a one-solve step
    (``max_sweeps = 1``) with the extrapolated predictor that has no acceleration to extrapolate
    (``state.accel`` None: the first step of a run, or of a restart from a checkpoint without
    ``state.accel``) is iterated to ``picard.tol``, at most :data:`STARTUP_SWEEPS` sweeps
    (docs/solver.md, "One solve per step": "The step without a^n").

    Why: a yield law lagged at ``u^n = 0`` holds. Solved once from rest, the regularised Coulomb
    base's viscosity ``mu_w p_wall / (2 eps)`` keeps a sliding block creeping (its base stress
    1.85 ``mu_w p_wall`` at 15 deg on tan 8 deg), and its slip grows only 2-4x a step until it
    reaches the inertial scale: about 5 steps of acceleration lost, 5.2 % of the analytic speed
    at t = 0.1 s with dt = 1 ms (2.3 % at 0.5 ms, 11.9 % at 2 ms; falling as 1/t); iterated in
    its first step, -0.22 % (the ambient's inertia: -0.13 %). The Drucker-Prager heap at 40 deg
    (validation/heap, 20 x 10) likewise started 0.03 s late with dt = 5 ms and was still flowing
    at 0.3 s; iterated in its first step it slumps and stops as the iterated loop's (0.27 s, the
    same surface change to 0.01 mm). Later steps extrapolate ``a^n``; a block launched up the
    slope reverses within 0.4 % of the analytic speed with one solve per step.
    """
    picard = model.picard
    if picard.max_sweeps == 1 and picard.predictor == Predictor.EXTRAPOLATED and state.accel is None:
        return STARTUP_SWEEPS
    return picard.max_sweeps


def minmod(a, b) -> np.ndarray:
    """``sign(a) min(|a|, |b|)`` where ``a`` and ``b`` have the same sign, else 0 (elementwise).

    >>> minmod(np.array([1.0, -2.0, 3.0, 0.0]), np.array([2.0, -1.0, -3.0, 5.0])).tolist()
    [1.0, -1.0, 0.0, 0.0]

    Computed as the median of ``(a, b, 0)``, ``max(min(a, b), min(max(a, b), 0))``: the same
    values (each is ``a``, ``b`` or 0) in four passes instead of eight (a whole-grid array per
    step; half the time at 256^2).
    """
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    low = np.minimum(a, b)
    high = np.maximum(a, b)
    np.minimum(high, 0.0, out=high)
    return np.maximum(low, high, out=low)
