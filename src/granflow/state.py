"""State of the solver: the fields of the model on the MAC grid and the clock (NUMERICS.md §13).

=========  ==========================  ==========================================================
field      shape                       meaning
=========  ==========================  ==========================================================
``phi``    ``(nx, nz)``                solid volume fraction at cell centres [-] (paper eq. syst1b)
``vel``    ``(grid.n_unknowns,)``      solid velocity on the interior faces, u then w [m s^-1]
                                       (:meth:`granflow.grid.Grid.pack_velocity`)
``p``      ``(nx, nz)``                granular pressure at cell centres [Pa] (p >= 0; p = 0 in
                                       the ambient and in "free" cells, NUMERICS.md §5.4)
``p_f``    ``(nx, nz)``                pore-gas over-pressure at cell centres [Pa] (zero in the
                                       dry model)
``c``      ``(nx, nz)`` or None        material fraction [-] (``numerics.surface = "indicator"``,
                                       :mod:`granflow.physics.material`; None otherwise)
``accel``  ``(grid.n_unknowns,)`` or     mean acceleration of the last accepted step,
           None                        ``(u^n - u^(n-1)) / dt_(n-1)`` [m s^-2] (the Picard
                                       predictor ``"extrapolated"``); None before the first
                                       step and after a restart from a checkpoint without it
``accel_dt`` scalar or None            that step's length ``dt_(n-1)`` [s]
``accel_prev`` as ``accel``               the same of the step before (the predictor's limiter)
``free``   ``(nx, nz)`` bool or None   the active set's free cells at the end of the last
                                       accepted step (one solve per step carries their
                                       interior, :mod:`granflow.active_set`); None before the
                                       first step and after a restart from a checkpoint without it
``t``      scalar                      time [s]
``step``   scalar                      number of accepted steps
=========  ==========================  ==========================================================

A :class:`State` is mutable: :meth:`granflow.model.Model.advance` updates it in place, and the
:class:`granflow.simulation.Simulation` keeps a :meth:`State.copy` to restore a rejected step.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from granflow.errors import GranflowInputError
from granflow.grid import Grid

OPTIONAL_FIELDS = ("c", "accel", "accel_prev", "free")
"""Array fields that may be None (checked only when present)."""


def _field(name: str, value, shape: tuple[int, ...]) -> np.ndarray:
    a = np.array(value, dtype=float)  # always a private copy
    if a.ndim == 0:
        a = np.full(shape, float(a))
    if a.shape != shape:
        raise GranflowInputError(f"State: {name} must have shape {shape}, got {a.shape}")
    return a


@dataclass(eq=False)
class State:
    """Fields and clock of a run (see the module docstring for shapes and units).

    Parameters
    ----------
    phi : ndarray, (nx, nz)
        Solid volume fraction [-].
    vel : ndarray, (n_unknowns,)
        Velocity unknowns [m s^-1].
    p : ndarray, (nx, nz)
        Granular pressure [Pa].
    p_f : ndarray, (nx, nz)
        Pore-gas over-pressure [Pa].
    t : float
        Time [s].
    step : int
        Number of accepted steps.
    c : ndarray, (nx, nz), optional
        Material fraction [-] of the indicator surface (:mod:`granflow.physics.material`);
        None for the threshold surface.
    accel : ndarray, (n_unknowns,), optional
        Mean acceleration of the last accepted step [m s^-2] (set by
        :meth:`granflow.model.Model.advance`; read by the Picard predictor ``"extrapolated"``,
        :class:`granflow.model_options.Predictor`). None before the first step.
    accel_dt : float, optional
        Length [s] of the step over which ``accel`` was measured (the predictor extrapolates
        over at most this long). None before the first step.
    accel_prev : ndarray, (n_unknowns,), optional
        ``accel`` of the step before the last [m s^-2] (the predictor limits the extrapolation
        with it, :func:`granflow.step.first_iterate`). None before the second step.
    free : ndarray of bool, (nx, nz), optional
        Free cells of the active set at the end of the last accepted step (set by
        :meth:`granflow.model.Model.advance`; read by :func:`granflow.active_set.carried_free`).
        None before the first step.
    """

    phi: np.ndarray
    vel: np.ndarray
    p: np.ndarray
    p_f: np.ndarray
    t: float = 0.0
    step: int = 0
    c: np.ndarray | None = None
    accel: np.ndarray | None = None
    accel_dt: float | None = None
    accel_prev: np.ndarray | None = None
    free: np.ndarray | None = None

    @classmethod
    def at_rest(cls, grid: Grid, phi, p=0.0, p_f=0.0, t: float = 0.0, c=None) -> State:
        """A state with zero velocity.

        Parameters
        ----------
        grid : Grid
        phi : array_like, (nx, nz) or scalar
            Solid volume fraction [-].
        p, p_f : array_like or float, optional
            Granular and pore pressures [Pa]; default 0 (see
            :meth:`granflow.model.Model.initial_state` for a lithostatic ``p``).
        t : float
            Initial time [s].
        c : array_like, optional
            Material fraction [-] (indicator surface); None: no indicator.

        Examples
        --------
        >>> from granflow.grid import Grid
        >>> s = State.at_rest(Grid(nx=3, nz=2, Lx=3.0, Lz=2.0), phi=0.6)
        >>> s.vel.shape, float(s.phi.sum())
        ((7,), 3.6)
        """
        shape = grid.cell_shape
        return cls(
            phi=_field("phi", phi, shape),
            vel=np.zeros(grid.n_unknowns),
            p=_field("p", p, shape),
            p_f=_field("p_f", p_f, shape),
            t=float(t),
            step=0,
            c=None if c is None else _field("c", c, shape),
        )

    def check(self, grid: Grid) -> None:
        """Raise :class:`GranflowInputError` if a field does not fit ``grid``."""
        for name, shape in (("phi", grid.cell_shape), ("p", grid.cell_shape),
                            ("p_f", grid.cell_shape), ("vel", (grid.n_unknowns,)), ("c", grid.cell_shape),
                            ("accel", (grid.n_unknowns,)), ("accel_prev", (grid.n_unknowns,)),
                            ("free", grid.cell_shape)):
            a = getattr(self, name)
            if name in OPTIONAL_FIELDS and a is None:
                continue
            if not isinstance(a, np.ndarray) or a.shape != shape:
                got = getattr(a, "shape", type(a).__name__)
                raise GranflowInputError(f"State: {name} must have shape {shape}, got {got}")

    def copy(self) -> State:
        """Deep copy (independent arrays)."""
        return State(phi=self.phi.copy(), vel=self.vel.copy(), p=self.p.copy(),
                     p_f=self.p_f.copy(), t=self.t, step=self.step,
                     c=None if self.c is None else self.c.copy(),
                     accel=None if self.accel is None else self.accel.copy(), accel_dt=self.accel_dt,
                     accel_prev=None if self.accel_prev is None else self.accel_prev.copy(),
                     free=None if self.free is None else self.free.copy())

    def restore(self, other: State) -> None:
        """Overwrite this state, in place, with a copy of ``other`` (undo a rejected step)."""
        self.phi = other.phi.copy()
        self.vel = other.vel.copy()
        self.p = other.p.copy()
        self.p_f = other.p_f.copy()
        self.c = None if other.c is None else other.c.copy()
        self.accel = None if other.accel is None else other.accel.copy()
        self.accel_dt = other.accel_dt
        self.accel_prev = None if other.accel_prev is None else other.accel_prev.copy()
        self.free = None if other.free is None else other.free.copy()
        self.t = other.t
        self.step = other.step

    def is_finite(self) -> bool:
        """True if every field is finite (the default NaN check of the Simulation)."""
        fields = (self.phi, self.vel, self.p, self.p_f) + tuple(
            a for a in (self.c, self.accel, self.accel_prev) if a is not None)
        return bool(all(np.all(np.isfinite(a)) for a in fields)
                    and np.isfinite(self.t))
