"""Registry of linear solvers with one interface (issue "solver" item 8; NUMERICS.md §3.1, §12).

Every solver is built by :func:`make_linear_solver` and called as

    x, info = solver.solve(matrix, rhs, x0=None, change=MatrixChange.AUTO, hints=None)

``info`` is a :class:`SolveInfo` (iterations, true relative residual, set-up and solve wall
times, whether the preconditioner or factorisation was rebuilt). A solver is stateful: it keeps
its factorisation or multigrid hierarchy between calls and reuses it when the sparsity pattern
(and, for ``"direct"``, the values) did not change. Registered solvers:

``"direct"``  (:class:`DirectSolver`) SuperLU (``scipy.sparse.linalg.splu``); the
              factorisation is reused when the matrix is unchanged (same pattern and values,
              detected, or asserted with ``change=MatrixChange.NONE``).
``"amg"``     (:class:`granflow.solvers.saddle.BlockAMGSolver`) FGMRES with a block
              upper-triangular preconditioner for the (u, p[, p_f]) saddle-point system of
              :meth:`granflow.model.Model.advance`: smoothed-aggregation AMG V-cycle on the
              velocity block, AMG on a Schur-complement approximation (Cahouet-Chabard /
              least-squares commutator), hierarchy reuse across Picard sweeps and steps.
``"amg_cg"``  (:class:`AMGConjugateGradient`) SA-AMG preconditioned CG for symmetric positive
              definite systems: Poisson/Helmholtz problems such as the pressure step (P) of
              NUMERICS.md §3.2 or an implicit diffusion step.

Iterative solvers raise :class:`LinearSolverError` when they do not reach their tolerance (the
Model turns any exception of the solve into a rejected step, retried with a smaller dt).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from enum import Enum
from typing import Any, ClassVar, Mapping

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from pydantic import Field

from granflow.errors import GranflowError, GranflowInputError
from granflow.params import Params, build
from granflow.registry import Registry

DEFAULT_RTOL = 1.0e-8
"""Default relative residual of the iterative solvers (in their scaled norm)."""
DEFAULT_MAX_ITERATIONS = 300
"""Default cap on Krylov iterations."""
DEFAULT_MAX_COARSE = 300
"""Largest coarsest-level size of the AMG hierarchies (solved by sparse LU)."""
DEFAULT_STRENGTH_THETA = 0.0
"""Strength-of-connection threshold of smoothed aggregation (PyAMG default; 0.25 coarsens the
velocity block too aggressively: 18 instead of 8 AMG-CG iterations, measured at 160 x 60)."""


class LinearSolverError(GranflowError):
    """An iterative solve did not converge, or produced non-finite values."""


class MatrixChange(str, Enum):
    """What changed in the matrix since the previous call of the same solver."""

    AUTO = "auto"
    """Unknown: the solver compares the sparsity pattern (and values, for ``"direct"``)."""
    NONE = "none"
    """Same matrix (same pattern and values): factorisations/hierarchies are reused as is."""
    VALUES = "values"
    """Same sparsity pattern, new values (e.g. the next Picard sweep)."""
    PATTERN = "pattern"
    """Anything may have changed (e.g. the active set): rebuild."""


@dataclass(frozen=True)
class SolveInfo:
    """Outcome of one :meth:`LinearSolver.solve`.

    Attributes
    ----------
    solver : str
        Registry name.
    iterations : int
        Krylov iterations (0 for the direct solver).
    residual : float
        True relative residual ``|rhs - A x| / |rhs|`` (2-norm, unscaled) [-].
    scaled_residual : float
        Relative residual in the norm the solver converges in (equal to ``residual`` for
        the direct solver and ``amg_cg``; the diagonally scaled system for ``amg``) [-].
    setup_time : float
        Wall time of the factorisation / hierarchy set-up during this call [s].
    solve_time : float
        Wall time of the triangular solves / Krylov iterations [s].
    rebuilt : bool
        True if the factorisation or a hierarchy was (re)built during this call.
    converged : bool
    error : ndarray or None
        ``A x - rhs`` of the returned solution when the solver computed it for ``residual``
        (PARDISO and SuperLU), else None: the caller that books the solve's error (the energy
        budget, :func:`granflow.step.solve_error`) then need not multiply again.
    """

    solver: str
    iterations: int
    residual: float
    scaled_residual: float
    setup_time: float
    solve_time: float
    rebuilt: bool
    converged: bool = True
    error: np.ndarray | None = field(default=None, repr=False, compare=False)


def same_pattern(a: sp.spmatrix, b: sp.spmatrix | None) -> bool:
    """True if two compressed sparse matrices of the same format have the same sparsity pattern
    (shape, ``indptr`` and ``indices``; both in canonical format). O(nnz)."""
    return (b is not None and a.format == b.format and a.shape == b.shape
            and np.array_equal(a.indptr, b.indptr) and np.array_equal(a.indices, b.indices))


def canonical(A, fmt: str) -> sp.spmatrix:
    """``A`` as a canonical (sorted, duplicate-free) float64 sparse matrix of format ``fmt``."""
    if not sp.issparse(A):
        raise GranflowInputError(f"linear solver: expected a scipy sparse matrix, got {type(A).__name__}")
    M = A.asformat(fmt).astype(float, copy=False)
    if not M.has_canonical_format:
        M = M.copy()
        M.sum_duplicates()
    return M


def relative_residual(A, x, b) -> float:
    """``|b - A x| / |b|`` (``|b - A x|`` if ``b = 0``)."""
    return residual_and_error(A, x, b)[0]


def residual_and_error(A, x, b) -> tuple[float, np.ndarray]:
    """``(|A x - b| / |b|, A x - b)``: :func:`relative_residual` and the vector it is the norm of
    (:attr:`SolveInfo.error`), from one product."""
    r = A @ x - b
    nb = float(np.linalg.norm(b))
    nr = float(np.linalg.norm(r))
    return (nr / nb if nb > 0 else nr), r


def check_system(A, rhs, x0=None) -> tuple[np.ndarray, np.ndarray | None]:
    """Validate shapes and finiteness of ``rhs`` and ``x0`` against the square matrix ``A``."""
    n = A.shape[0]
    if A.shape != (n, n):
        raise GranflowInputError(f"linear solver: matrix must be square, got {A.shape}")
    b = np.asarray(rhs, dtype=float)
    if b.shape != (n,) or not np.all(np.isfinite(b)):
        raise GranflowInputError(f"linear solver: rhs must be a finite vector of length {n}, got shape {b.shape}")
    if x0 is None:
        return b, None
    x = np.asarray(x0, dtype=float)
    if x.shape != (n,):
        raise GranflowInputError(f"linear solver: x0 must have length {n}, got shape {x.shape}")
    return b, np.where(np.isfinite(x), x, 0.0)


class LinearSolver:
    """Base class: a stateful solver of ``A x = b`` (see the module docstring).

    Subclasses define ``Parameters`` (a :class:`granflow.params.Params` model) and
    :meth:`solve`; ``name`` is set by the registry.
    """

    name: ClassVar[str] = "linear_solver"

    class Parameters(Params):
        """No parameters."""

    def __init__(self, params: Params) -> None:
        self.params = params

    def solve(self, matrix, rhs, x0=None, change: MatrixChange | str = MatrixChange.AUTO,
              hints=None) -> tuple[np.ndarray, SolveInfo]:
        """Solve ``matrix @ x = rhs``.

        Parameters
        ----------
        matrix : scipy sparse matrix, (N, N)
        rhs : ndarray, (N,)
        x0 : ndarray, (N,), optional
            Initial guess (iterative solvers; ignored by ``"direct"``).
        change : MatrixChange or str
            What changed since the previous call (default: detect).
        hints : object, optional
            Solver-specific extra information (``"amg"``: :class:`granflow.solvers.saddle.SaddleHints`).

        Returns
        -------
        x : ndarray, (N,)
        info : SolveInfo
        """
        raise NotImplementedError

    def reset(self) -> None:
        """Forget every cached factorisation/hierarchy."""

    def begin_step(self) -> None:
        """Called by :meth:`granflow.model.Model.advance` before the first sweep of each step. The
        exact solvers forget here whatever cached set-up depends on the values of earlier matrices
        (``pardiso``'s analysis), so that a step's result depends only on the state it starts from
        and restarts are bit-identical. The AMG solvers (``amg``, ``amg_cg``) keep their
        hierarchies across steps (rebuilding them each step would cost a set-up per step): their
        restarts agree with a continued run to the Krylov tolerance, not bit for bit."""

    def forget(self) -> None:
        """End any window over which set-up is kept across steps (``pardiso``'s
        ``analysis_steps``). No-op by default."""

    def checkpoint_payload(self) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """``(arrays, scalars)`` of the set-up kept across steps that the next steps' results depend
        on (``pardiso``'s kept analysis), for a restart that continues bit for bit; none by default."""
        return {}, {}

    def restore_checkpoint(self, arrays: Mapping[str, Any], scalars: Mapping[str, Any]) -> None:
        """Take up a :meth:`checkpoint_payload` (keys as it wrote them). No-op by default."""

    def describe(self) -> dict[str, Any]:
        """Name and parameters (for reports and output metadata)."""
        return {"name": self.name, **self.params.model_dump()}


LINEAR_SOLVERS: Registry[LinearSolver] = Registry("linear solver")


def make_linear_solver(name: str, **params: Any) -> LinearSolver:
    """Build a registered linear solver with validated keyword parameters.

    Parameters
    ----------
    name : str
        ``"direct"``, ``"amg"`` or ``"amg_cg"`` (``LINEAR_SOLVERS.names()``).
    **params
        The solver's parameters (its ``Parameters`` model; unknown keys are errors).

    Examples
    --------
    >>> import numpy as np, scipy.sparse as sp
    >>> solver = make_linear_solver("direct")
    >>> x, info = solver.solve(sp.diags([2.0, 4.0]).tocsc(), np.array([2.0, 2.0]))
    >>> x.tolist(), info.iterations
    ([1.0, 0.5], 0)
    """
    cls = LINEAR_SOLVERS.get(name)
    return cls(build(cls.Parameters, params, context=f"linear_solver {name!r}"))


@LINEAR_SOLVERS.register("direct")
class DirectSolver(LinearSolver):
    """Sparse LU (SuperLU, COLAMD column ordering) with reuse of the factorisation.

    The factorisation is reused when ``change`` is ``NONE``, or (``AUTO``) when the matrix has
    the same pattern and the same values as the previous one (an O(nnz) comparison). SuperLU
    cannot reuse a symbolic factorisation for new values (re-using its column permutation with
    ``permc_spec="NATURAL"`` was measured 100x slower, because the elimination-tree postorder is
    lost), so ``VALUES`` refactorises. Cost measured on the collapse systems: N^1.4 for N = 5e3 to
    8e4 unknowns (benchmarks/linear_solvers.py).
    """

    class Parameters(Params):
        """Parameters of the direct solver.

        Attributes
        ----------
        permc_spec : str
            SuperLU column ordering: ``"COLAMD"`` (default), ``"MMD_AT_PLUS_A"``,
            ``"MMD_ATA"`` or ``"NATURAL"``.
        """

        permc_spec: str = Field("COLAMD", pattern="^(COLAMD|MMD_AT_PLUS_A|MMD_ATA|NATURAL)$",
                                description="SuperLU column ordering")

    def __init__(self, params: Params) -> None:
        super().__init__(params)
        self.reset()

    def reset(self) -> None:
        self._lu = None
        self._matrix: sp.csc_matrix | None = None

    def solve(self, matrix, rhs, x0=None, change=MatrixChange.AUTO, hints=None):
        change = MatrixChange(change)
        A = canonical(matrix, "csc")
        b, _ = check_system(A, rhs)
        t0 = time.perf_counter()
        reuse = self._lu is not None and (
            (change is MatrixChange.NONE and self._matrix is not None and self._matrix.shape == A.shape)
            or (change is MatrixChange.AUTO and same_pattern(A, self._matrix)
                and np.array_equal(A.data, self._matrix.data)))
        if not reuse:
            self._lu = spla.splu(A, permc_spec=self.params.permc_spec)
            self._matrix = A
        t1 = time.perf_counter()
        x = self._lu.solve(b)
        t2 = time.perf_counter()
        if not np.all(np.isfinite(x)):
            raise LinearSolverError("direct solver: non-finite solution (singular matrix?)")
        res, error = residual_and_error(A, x, b)
        return x, SolveInfo(solver=self.name, iterations=0, residual=res, scaled_residual=res,
                            setup_time=t1 - t0, solve_time=t2 - t1, rebuilt=not reuse, error=error)


@LINEAR_SOLVERS.register("amg_cg")
class AMGConjugateGradient(LinearSolver):
    """Smoothed-aggregation AMG (one V-cycle) as the preconditioner of CG, for symmetric positive
    definite systems (variable-coefficient Poisson/Helmholtz, NUMERICS.md §3.2 (P)).

    The hierarchy is rebuilt when the sparsity pattern changes (or ``change=PATTERN``) and, for
    new values on the same pattern, only if the previous solve needed more than
    ``rebuild_factor`` times the iterations of the first solve with the current hierarchy.
    """

    class Parameters(Params):
        """Parameters of SA-AMG + CG.

        Attributes
        ----------
        rtol : float
            Relative residual ``|b - A x| <= rtol |b|``. Default 1e-8.
        max_iterations : int
            Default 300.
        strength_theta : float
            SA strength threshold. Default 0.
        rebuild_factor : float
            Rebuild a reused hierarchy when the iterations exceed this factor times those of
            its first solve. Default 1.5.
        """

        rtol: float = Field(DEFAULT_RTOL, gt=0, lt=1, description="relative residual")
        max_iterations: int = Field(DEFAULT_MAX_ITERATIONS, ge=1, description="CG iteration cap")
        strength_theta: float = Field(DEFAULT_STRENGTH_THETA, ge=0, lt=1, description="SA strength threshold")
        rebuild_factor: float = Field(1.5, ge=1, description="iteration growth that triggers a rebuild")

    def __init__(self, params: Params) -> None:
        super().__init__(params)
        self.reset()

    def reset(self) -> None:
        self._ml = None
        self._pattern: sp.csr_matrix | None = None
        self._base_iterations = 0
        self._stale = False

    def solve(self, matrix, rhs, x0=None, change=MatrixChange.AUTO, hints=None):
        change = MatrixChange(change)
        A = canonical(matrix, "csr")
        import pyamg  # lazily (granflow.solvers.amg)

        b, x0 = check_system(A, rhs, x0)
        t0 = time.perf_counter()
        rebuild = (self._ml is None or change is MatrixChange.PATTERN or self._stale
                   or (change is not MatrixChange.NONE and not same_pattern(A, self._pattern)))
        if rebuild:
            self._ml = pyamg.smoothed_aggregation_solver(
                A, strength=("symmetric", {"theta": self.params.strength_theta}),
                max_coarse=DEFAULT_MAX_COARSE, coarse_solver="splu")
            self._pattern = A
            self._stale = False
        t1 = time.perf_counter()
        history: list[float] = []
        x, flag = pyamg.krylov.cg(A, b, x0=x0, tol=self.params.rtol, maxiter=self.params.max_iterations,
                                  M=self._ml.aspreconditioner(), residuals=history)
        t2 = time.perf_counter()
        its = max(len(history) - 1, 0)
        if rebuild:
            self._base_iterations = max(its, 1)
        elif its > self.params.rebuild_factor * self._base_iterations:
            self._stale = True
        res = relative_residual(A, x, b)
        if flag != 0 or not np.all(np.isfinite(x)):
            raise LinearSolverError(f"amg_cg: relative residual {res:.3g} > rtol {self.params.rtol:.3g} "
                                    f"after {its} iterations")
        return x, SolveInfo(solver=self.name, iterations=its, residual=res, scaled_residual=res,
                            setup_time=t1 - t0, solve_time=t2 - t1, rebuilt=rebuild)
