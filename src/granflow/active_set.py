"""The active set's start of a step: which dense cells begin the step free (NUMERICS.md §5.4).

A dense cell is *active* (its pressure ``p >= 0`` is an unknown and its dilatancy law
``div u = b - C p`` a row; paper eq. syst4DP) or *free* (``p = 0``, ``div u >= b``). The Picard loop
of :func:`granflow.step.implicit_stage` frees an active cell whose solved pressure is negative and
re-activates a free cell that would compact (``div u < b``), sweep after sweep, so its converged
set does not depend on where it starts. With one solve per step (``numerics.picard.max_sweeps =
1``) the start *is* the answer:

- Every dense cell starting active (the loop's start) keeps a bed that the gas could lift
  forever at rest: a bed injected at U = 1.1 U_mf (validation/roche, small bed) solves to
  ``p < 0`` everywhere -- the tension holds it packed -- and is reset to active at the next step,
  so it never expands (phi 0.600 against the model's 0.5895).
- Carrying the whole free set of the last step expands it, but the cells it frees at the free
  surface of a collapsing column compact a step late: the Lagree 128^2 deposit moved from
  4.3e-3 to 7.3e-3 of the iterated one (docs/solver.md, "One solve per step").

:func:`carried_free` carries only the *interior* part of the last step's free set: the cells
whose four neighbours are dense and not thin surface cells (a wall counts as a dense
neighbour; a periodic x boundary wraps). The gas-supported bed is interior; the cells a
collapsing column frees are at its surface: in the Lagree 128^2 run every freed cell was, and the
deposit is unchanged to the last digit (measured 2026-12-06, docs/solver.md).
"""
from __future__ import annotations

import numpy as np


def never_active(thin, source, dense) -> np.ndarray | None:
    """The dense cells that never get a row: the thin cells of the indicator surface (``thin``,
    None for the threshold surface) and a source's cells (``source``: its
    :class:`granflow.physics.inflow.SourceTerms` or None); None if there are none."""
    fixed = thin
    if source is not None:
        fixed = source.cells & dense if fixed is None else fixed | (source.cells & dense)
    return fixed


def initial_free(ex, dense) -> tuple[np.ndarray, np.ndarray | None]:
    """The active set's start: every dense cell is active (p < 0 frees it) but the cells that
    never get a row (:func:`never_active`; the second mask, None if there are none). ``ex`` is the
    step's :class:`granflow.step.Explicit`."""
    fixed = never_active(ex.thin, ex.source, dense)
    return (np.zeros_like(dense) if fixed is None else fixed.copy()), fixed


def interior(grid, cells: np.ndarray) -> np.ndarray:
    """Cells of the boolean field ``cells`` (flat, ``grid.cell_shape`` order) whose four
    neighbours are in it too; outside a wall counts as in, a periodic x boundary wraps.

    >>> from granflow.grid import Grid
    >>> g = Grid(nx=3, nz=3, Lx=3.0, Lz=3.0)
    >>> m = np.ones(9, dtype=bool); m[8] = False          # the top right cell out
    >>> interior(g, m).reshape(3, 3).astype(int).tolist()
    [[1, 1, 1], [1, 1, 0], [1, 0, 0]]
    """
    nx, nz = grid.cell_shape
    a = np.asarray(cells, dtype=bool).reshape(nx, nz)
    padded = np.pad(a, ((0, 0), (1, 1)), constant_values=True)
    padded = (np.pad(padded, ((1, 1), (0, 0)), mode="wrap") if grid.periodic_x
              else np.pad(padded, ((1, 1), (0, 0)), constant_values=True))
    inner = a & padded[2:, 1:-1] & padded[:-2, 1:-1] & padded[1:-1, 2:] & padded[1:-1, :-2]
    return inner.ravel()


def carried_free(model, state, ex, dense) -> np.ndarray | None:
    """The free cells one solve per step starts from besides :func:`initial_free`'s (flat
    boolean, or None): the last accepted step's free cells (``state.free``) that are dense now and
    :func:`interior` to the dense, non-thin cells (the module docstring says why only those).
    None with the Picard loop (``max_sweeps > 1``: warm starts of its set measured slower,
    docs/solver.md) and before the first step."""
    if model.picard.max_sweeps > 1 or state.free is None:
        return None
    body = dense if ex.thin is None else dense & ~ex.thin
    return np.asarray(state.free, dtype=bool).ravel() & interior(model.grid, body)


def start_free(model, state, ex, dense) -> tuple[np.ndarray, np.ndarray | None]:
    """The free cells a step starts from and the never-active ones: :func:`initial_free`, plus
    :func:`carried_free` with one solve per step."""
    free, fixed = initial_free(ex, dense)
    carried = carried_free(model, state, ex, dense)
    if carried is not None:
        free |= carried
    return free, fixed
