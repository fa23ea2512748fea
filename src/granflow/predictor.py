"""The Picard loop's first iterate (``numerics.picard.predictor``, :class:`granflow.model_options.
Predictor`; docs/solver.md, "One solve per step"): ``u^n``, or a limited linear extrapolation in
time from the last two steps' mean accelerations (:attr:`granflow.state.State.accel`,
``accel_prev``), which :meth:`granflow.model.Model.advance` stores with that predictor.
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


def minmod(a, b) -> np.ndarray:
    """``sign(a) min(|a|, |b|)`` where ``a`` and ``b`` have the same sign, else 0 (elementwise).

    >>> minmod(np.array([1.0, -2.0, 3.0, 0.0]), np.array([2.0, -1.0, -3.0, 5.0])).tolist()
    [1.0, -1.0, 0.0, 0.0]
    """
    return np.where(a * b > 0, np.sign(a) * np.minimum(np.abs(a), np.abs(b)), 0.0)
