"""Smoothed-aggregation AMG hierarchies with reuse, and the near-null space of the MAC velocity
block (NUMERICS.md §3.1, §12; issue "performance" item 2).

PyAMG (Olson & Schroder, https://github.com/pyamg/pyamg) builds a smoothed-aggregation
hierarchy: strength graph, aggregates, tentative prolongator from the near-null-space candidates
``B``, Jacobi-smoothed prolongator ``P``, Galerkin coarse operators ``R A P``. The set-up costs
several V-cycles, so :class:`Hierarchy` keeps it between the Picard sweeps and time steps of the
solver, with three policies (:class:`Reuse`):

* ``NEVER``: a new hierarchy for every matrix;
* ``LAGGED``: keep the hierarchy of an older matrix of the same sparsity pattern as the
  preconditioner of the new one (the Krylov method still solves the current matrix exactly to
  its tolerance) until the caller marks it stale;
* ``REFRESH``: keep the aggregates and prolongators, recompute the Galerkin coarse operators and
  the smoothers for the new values (a third of a full set-up: 0.10 s against 0.3 s for the
  velocity block of 336 x 126 cells, measured).

A change of sparsity pattern always rebuilds.
"""
from __future__ import annotations

from enum import Enum

import numpy as np
import scipy.sparse as sp

from granflow.grid import Grid

SMOOTHER = ("block_gauss_seidel", {"sweep": "symmetric"})
"""Pre- and post-smoother (the PyAMG default for SA)."""
COARSE_SOLVER = "splu"
"""Coarsest-level solver (sparse LU; the PyAMG default, a dense pseudo-inverse, costs seconds
when the rotation/dilation candidates make the coarsest level a few thousand unknowns)."""
SYMMETRY_TOLERANCE = 1.0e-12
"""Relative size of ``A - A^T`` below which a matrix is treated as symmetric."""


class Reuse(str, Enum):
    """What a :class:`Hierarchy` keeps when the values of its matrix change (module docstring)."""

    NEVER = "never"
    LAGGED = "lagged"
    REFRESH = "refresh"


def is_symmetric(A: sp.spmatrix) -> bool:
    """True if ``|A - A^T|_max <= SYMMETRY_TOLERANCE |A|_max``."""
    scale = abs(A).max() if A.nnz else 0.0
    return bool(A.nnz == 0 or abs(A - A.T).max() <= SYMMETRY_TOLERANCE * scale)


def velocity_near_nullspace(grid: Grid) -> np.ndarray:
    """Near-null-space candidates of the velocity block ``rho/dt + V(eta)`` on the MAC unknowns.

    The deviatoric viscous operator ``V`` (operators.py: ``ec u = du/dx - dw/dz``,
    ``en u = du/dz + dw/dx``) vanishes on every 2-D conformal (holomorphic) velocity field; the
    locally dominant ones are the two translations, the rotation ``(-z, x)`` and the isotropic
    dilation ``(x, z)``. In a region of large viscosity they are resisted only by the inertia
    ``rho/dt``, so smoothed aggregation must interpolate them (measured on the mid-collapse
    velocity block at 160 x 60 cells: 8 AMG-CG iterations with these four candidates, 14 with the
    two translations, 31 with the constant alone).

    Parameters
    ----------
    grid : Grid

    Returns
    -------
    ndarray, (grid.n_unknowns, 4)
        Columns: x-translation, z-translation, rotation, dilation; coordinates relative to the
        box centre, scaled by the largest box size [-].
    """
    Xu, Zu = grid.xface_coords()
    Xw, Zw = grid.zface_coords()
    cols = grid.u_columns  # interior x-faces, or all but the periodic image
    x = np.concatenate([Xu[cols].ravel(), Xw[:, 1:-1].ravel()])
    z = np.concatenate([Zu[cols].ravel(), Zw[:, 1:-1].ravel()])
    length = max(grid.Lx, grid.Lz)
    x = (x - (grid.x0 + 0.5 * grid.Lx)) / length
    z = (z - (grid.z0 + 0.5 * grid.Lz)) / length
    is_u = np.zeros(grid.n_unknowns, dtype=bool)
    is_u[grid.u_slice] = True
    return np.column_stack([is_u.astype(float), (~is_u).astype(float),
                            np.where(is_u, -z, x), np.where(is_u, x, z)])


class Hierarchy:
    """A smoothed-aggregation hierarchy for a sequence of matrices, with reuse.

    Parameters
    ----------
    reuse : Reuse or str
    strength_theta : float
        SA strength-of-connection threshold.
    max_coarse : int
        Largest coarsest-level size.
    """

    def __init__(self, reuse: Reuse | str, strength_theta: float, max_coarse: int) -> None:
        self.reuse = Reuse(reuse)
        self.strength_theta = float(strength_theta)
        self.max_coarse = int(max_coarse)
        self.ml = None
        self._pattern: sp.csr_matrix | None = None
        self._symmetry = "hermitian"
        self.stale = False
        """Set by the caller when the reused hierarchy has become a poor preconditioner."""
        self.builds = 0
        self.refreshes = 0

    def update(self, A: sp.csr_matrix, B: np.ndarray | None = None, same_values: bool = False) -> bool:
        """Make the hierarchy a preconditioner of ``A`` (canonical CSR).

        Parameters
        ----------
        A : csr_matrix
        B : ndarray, (n, k), optional
            Near-null-space candidates (default: the constant vector).
        same_values : bool
            The caller asserts that ``A`` equals the matrix of the previous call.

        Returns
        -------
        bool
            True if a full set-up was done.
        """
        same = self.ml is not None and not self.stale and (same_values or self._same_pattern(A))
        if same and (same_values or self.reuse is Reuse.LAGGED):
            return False
        if same and self.reuse is Reuse.REFRESH:
            self._refresh(A)
            return False
        self._symmetry = "hermitian" if is_symmetric(A) else "nonsymmetric"
        if B is not None and B.shape[0] != A.shape[0]:
            B = None
        import pyamg  # lazily: a run on PARDISO or SuperLU never loads it (77 ms a process)

        self.ml = pyamg.smoothed_aggregation_solver(
            A, B=B, symmetry=self._symmetry,
            strength=("symmetric", {"theta": self.strength_theta}), max_coarse=self.max_coarse,
            presmoother=SMOOTHER, postsmoother=SMOOTHER, coarse_solver=COARSE_SOLVER)
        self._pattern = A
        self.stale = False
        self.builds += 1
        return True

    def _same_pattern(self, A: sp.csr_matrix) -> bool:
        P = self._pattern
        return (P is not None and A.shape == P.shape and np.array_equal(A.indptr, P.indptr)
                and np.array_equal(A.indices, P.indices))

    def _refresh(self, A: sp.csr_matrix) -> None:
        """New values, same aggregates and prolongators: Galerkin products and smoothers again."""
        from pyamg.multilevel import coarse_grid_solver
        from pyamg.relaxation.smoothing import change_smoothers

        levels = self.ml.levels
        A.symmetry = self._symmetry
        levels[0].A = A
        for fine, coarse in zip(levels[:-1], levels[1:]):
            Ac = fine.R @ fine.A @ fine.P
            if sp.issparse(coarse.A) and coarse.A.format == "bsr" and Ac.format != "bsr":
                Ac = Ac.tobsr(blocksize=coarse.A.blocksize)
            Ac.symmetry = self._symmetry
            coarse.A = Ac
        change_smoothers(self.ml, SMOOTHER, SMOOTHER)
        self.ml.coarse_solver = coarse_grid_solver(COARSE_SOLVER)
        self._pattern = A
        self.refreshes += 1

    def vcycle(self, r: np.ndarray) -> np.ndarray:
        """One V-cycle from a zero guess: an approximation of ``A^-1 r``."""
        return self.ml.solve(r, x0=np.zeros_like(r), tol=0.0, maxiter=1, cycle="V")
