"""Block-preconditioned FGMRES for the saddle-point systems of the solver (registry name ``"amg"``).

The system of one Picard sweep of :meth:`granflow.model.Model.advance` (NUMERICS.md §3.1) is

    [ A   B_u ] [u]   [f]        A = rho_f/dt + V(eta)     (SPD, n x n; velocity unknowns first)
    [ B_l C_b ] [q] = [g],       q = active p (then p_f, if a pore-pressure block is appended)

with, for (u, p) in the symmetric form of :class:`granflow.physics.momentum.SaddleAssembler`,
``B_u = Grad_act``, ``B_l = Grad_act^T = -Div_act`` and ``C_b = -diag(C)`` (C >= 0, the AP
dilatancy compaction term). Nothing below assumes symmetry or the number of trailing blocks: a
bordered p_f block (``[[K, G, G], [D, C, 0], [pD, 0, A_gas]]``) is handled by the same code.

Solver (Elman, Silvester & Wathen 2014, ch. 9; Benzi, Golub & Liesen 2005):

1. symmetric diagonal scaling ``K_s = D K D`` with ``D = diag(diag(A), |diag(S_1)|)^-1/2``,
   ``S_1 = C_b - B_l diag(A)^-1 B_u``, so that momentum and constraint rows are balanced in the
   convergence test (without it FGMRES stops with a 1e-2 pressure error at 1e-8 residual);
2. FGMRES (right preconditioning: the true residual of the scaled system is minimised) with the
   block upper-triangular preconditioner ``P = [[A^, B_u], [0, S^]]``:
   ``z_q = S^-1 r_q``, ``z_u = A^-1 (r_u - B_u z_q)``;
3. ``A^-1``: one smoothed-aggregation V-cycle (PyAMG), near-null space = translations, rotation
   and dilation of :func:`granflow.solvers.amg.velocity_near_nullspace` when the grid is known;
4. ``S^-1`` (:class:`Schur`), the Schur complement ``S = C_b - B_l A^-1 B_u``:

   * ``AUGMENTED`` (default when :class:`SaddleHints` are given): augmented Lagrangian (Benzi &
     Olshanskii 2006; Fortin & Glowinski). The viscous operator here is *deviatoric*
     (``-div(2 eta S_dev)``), which vanishes on every conformal velocity field (dilation, and
     higher harmonics near a free surface): in static, highly viscous regions these modes are
     resisted only by ``rho/dt`` (1e-3 .. 1e-4 of the viscous diagonal), the velocity block is
     nearly singular on a space whose size grows like the free-surface length, and both the AMG
     V-cycle and every Schur approximation below degrade with N (measured: 32, 50, 75, 78 FGMRES
     iterations on a static layer from 370 to 25k unknowns). Adding ``B_u Gamma`` times the
     constraint rows to the momentum rows, with ``Gamma = diag(eta/(1 + eta C))`` on the granular
     rows, gives the same solution and the velocity block ``A + B_u Gamma B_l``, i.e. (C -> 0)
     ``rho/dt - div(2 eta D(u))`` with the *full* strain rate: an elasticity-like operator
     whose near-null space (translations, rotation) smoothed aggregation handles. By Woodbury,
     ``-B_l (A + B_u Gamma B_l)^-1 B_u = -(X^-1 + Gamma)^-1``, ``X = -B_l A^-1 B_u``; with the
     Cahouet-Chabard symbol of X (below) and ``theta = 1/(1 + eta C)``,
     ``S ~ -(C + theta / (ell^-1 + eta + gamma))``, ``ell`` the ``rho/dt``-weighted Laplacian, which
     the additive split (factor-2 bound below) turns into
     ``S^-1 ~ -[(C + Theta^1/2 B_l M_rho^-1 B_u Theta^1/2)^-1 + diag(1/(C + theta/(eta + gamma)))]``:
     one V-cycle on a Poisson + reaction matrix plus a diagonal. Measured: 14-27 iterations for
     every state (static layer 18, 20, 23; collapse onset 19, 21, 28; mid-collapse 18, 15, 15,
     tests/integration/test_linear_solvers.py; 10-14 with warm starts, benchmarks/linear_solvers.py);
   * ``CAHOUET_CHABARD`` (needs hints): for the generalised Stokes operator
     ``rho/dt - div(2 eta S_dev)`` the symbol of ``-B A^-1 B^T`` is ``k^2/(rho/dt + eta k^2)``, whose
     inverse is *additive*: ``S^-1 ~ (rho/dt)^-1-weighted Laplacian^-1 + eta M_p^-1`` (Cahouet &
     Chabard 1988). With the compaction diagonal C this becomes
     ``S^-1 ~ (C + B_l M_rho^-1 B_u)^-1 + diag(1/(C + 1/eta))`` (granular rows), within a
     factor 2 of the exact symbol for every C >= 0 (``1/(C + ab/(a+b))`` against
     ``1/(C+a) + 1/(C+b)``). Grid-independent in flowing states (26, 23, 22 iterations), not in
     static ones (no augmentation);
   * ``LSC``: algebraic least-squares commutator (Elman et al. 2006) with ``W = diag(A)`` and C
     added symmetrically, ``S^-1 ~ L^-1 (C_b - B_l W^-1 A W^-1 B_u) L^-1``,
     ``L = C_b - B_l W^-1 B_u`` (two V-cycles on L); needs nothing but the matrix. Default
     without hints; 17, 18, 27 iterations mid-collapse;
   * ``DIAGONAL`` (SIMPLE): ``S^-1 ~ L^-1``; cheapest, but h-dependent for viscous flow.

   The approximation is sign-normalised (rows with a negative diagonal are flipped) before AMG,
   so that the symmetric (negative definite) pressure block gets an SPD hierarchy. Trailing
   blocks (p_f) get ``C_b - B_l W^-1 B_u`` only.

Hierarchy reuse (:class:`granflow.solvers.amg.Reuse`, default ``refresh``) across sweeps and
steps; warm start from ``x0``. ``SolveInfo.scaled_residual`` is that of the scaled (and, for
``AUGMENTED``, augmented) system; ``SolveInfo.residual`` is always that of the given system.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from enum import Enum
from typing import Any

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import LinearOperator
from pydantic import ConfigDict, Field, model_validator

from granflow.errors import GranflowInputError
from granflow.grid import Grid
from granflow.params import Params
from granflow.solvers.amg import Hierarchy, Reuse, velocity_near_nullspace
from granflow.solvers.linear import (DEFAULT_MAX_COARSE, DEFAULT_MAX_ITERATIONS, DEFAULT_RTOL,
                                     DEFAULT_STRENGTH_THETA, LINEAR_SOLVERS, LinearSolver,
                                     LinearSolverError, MatrixChange, SolveInfo, canonical,
                                     check_system, relative_residual)

DEFAULT_RESTART = 60
"""FGMRES restart length (memory: restart x N doubles)."""
DEFAULT_REBUILD_FACTOR = 1.5
"""A reused hierarchy is rebuilt when a solve needs this factor more iterations than the first
solve after the last build."""
TINY = 1.0e-300
"""Floor of diagonals before taking inverses."""


class Schur(str, Enum):
    """Schur-complement approximation (module docstring, item 4)."""

    AUTO = "auto"
    """``AUGMENTED`` if :class:`SaddleHints` are given, else ``LSC``."""
    AUGMENTED = "augmented"
    CAHOUET_CHABARD = "cahouet_chabard"
    LSC = "lsc"
    DIAGONAL = "diagonal"


@dataclass(frozen=True)
class SaddleHints:
    """Physical coefficients that the ``augmented`` and ``cahouet_chabard`` Schur approximations
    need.

    Attributes
    ----------
    mass : ndarray, (n,)
        Inertia part of the velocity block, ``rho_f/dt`` at the velocity unknowns
        [kg m^-3 s^-1].
    viscosity : ndarray, (k,)
        Viscosity [Pa s] at the first ``k`` unknowns of the pressure block (the active
        granular cells, in their order in the matrix: ``eta_c[active]``). Trailing unknowns
        (e.g. p_f) get no viscous term.
    """

    mass: np.ndarray
    viscosity: np.ndarray


class BlockAMGParameters(Params):
    """Parameters of the ``"amg"`` saddle-point solver.

    Attributes
    ----------
    n_velocity : int, optional
        Number of velocity unknowns (the leading block). Required unless ``grid`` is given.
    grid : Grid, optional
        The MAC grid: gives ``n_velocity`` and the rotation/dilation near-null space.
    rtol : float
        Relative residual of the diagonally scaled system. Default 1e-8.
    max_iterations : int
        FGMRES iteration cap (restarted every :data:`DEFAULT_RESTART`). Default 300.
    schur : Schur
        Default ``auto`` (``augmented`` with hints, ``lsc`` without).
    reuse : Reuse
        Hierarchy reuse policy; default ``refresh``.
    rebuild_factor : float
        Default 1.5 (:data:`DEFAULT_REBUILD_FACTOR`).
    strength_theta : float
        SA strength threshold. Default 0.
    raise_on_failure : bool
        Raise :class:`LinearSolverError` if the tolerance is not reached. Default True.
    """

    model_config = ConfigDict(arbitrary_types_allowed=True)

    n_velocity: int | None = Field(None, ge=1, description="number of velocity unknowns")
    grid: Grid | None = Field(None, description="MAC grid (near-null space, n_velocity)")
    rtol: float = Field(DEFAULT_RTOL, gt=0, lt=1, description="relative residual (scaled system)")
    max_iterations: int = Field(DEFAULT_MAX_ITERATIONS, ge=1, description="FGMRES iteration cap")
    schur: Schur = Field(Schur.AUTO, description="Schur-complement approximation")
    reuse: Reuse = Field(Reuse.REFRESH, description="AMG hierarchy reuse policy")
    rebuild_factor: float = Field(DEFAULT_REBUILD_FACTOR, ge=1, description="iteration growth that rebuilds")
    strength_theta: float = Field(DEFAULT_STRENGTH_THETA, ge=0, lt=1, description="SA strength threshold")
    raise_on_failure: bool = Field(True, description="raise LinearSolverError when not converged")

    @model_validator(mode="after")
    def _size(self) -> BlockAMGParameters:
        if self.grid is None and self.n_velocity is None:
            raise ValueError("give n_velocity (number of velocity unknowns) or grid")
        if self.grid is not None and self.n_velocity not in (None, self.grid.n_unknowns):
            raise ValueError(f"n_velocity = {self.n_velocity} but grid.n_unknowns = {self.grid.n_unknowns}")
        return self


def scale_symmetric(K: sp.csr_matrix, d: np.ndarray) -> sp.csr_matrix:
    """``diag(d) K diag(d)`` on the same sparsity pattern (explicit zeros kept, unlike a sparse
    product), canonical CSR."""
    out = K.copy()
    rows = np.repeat(np.arange(K.shape[0]), np.diff(K.indptr))
    out.data = K.data * d[rows] * d[K.indices]
    out.sort_indices()
    return out


@dataclass
class _Blocks:
    """Scaled blocks of one system."""

    K: sp.csr_matrix
    A: sp.csr_matrix
    Bu: sp.csr_matrix
    Bl: sp.csr_matrix
    Cb: sp.csr_matrix
    d: np.ndarray


@dataclass
class _Augmentation:
    """Augmented-Lagrangian system (unscaled) and its weights."""

    K: sp.csr_matrix
    b: np.ndarray
    gamma: np.ndarray
    """Augmentation weights per pressure-block unknown [Pa s]."""
    theta: np.ndarray
    """``1/(1 + eta C)`` per pressure-block unknown (1 on trailing blocks) [-]."""
    Bu: sp.csr_matrix
    """The original (unaugmented) velocity-pressure coupling."""

    def Bu_scaled(self, d: np.ndarray, n: int) -> sp.csr_matrix:
        return (sp.diags(d[:n]) @ self.Bu @ sp.diags(d[n:])).tocsr()


@LINEAR_SOLVERS.register("amg")
class BlockAMGSolver(LinearSolver):
    """FGMRES + block-triangular AMG preconditioner for the saddle-point system (module docstring).

    Build with ``make_linear_solver("amg", grid=grid)`` (or ``n_velocity=...``). ``solve`` takes
    the assembled matrix (velocity unknowns first), the right-hand side, an optional warm start
    ``x0`` and optional :class:`SaddleHints`.
    """

    Parameters = BlockAMGParameters

    def __init__(self, params: BlockAMGParameters) -> None:
        super().__init__(params)
        self.n = params.grid.n_unknowns if params.grid is not None else int(params.n_velocity)
        self.near_nullspace = velocity_near_nullspace(params.grid) if params.grid is not None else None
        self.reset()

    def reset(self) -> None:
        p = self.params
        self.velocity = Hierarchy(p.reuse, p.strength_theta, DEFAULT_MAX_COARSE)
        self.pressure = Hierarchy(p.reuse, p.strength_theta, DEFAULT_MAX_COARSE)
        self._base_iterations = 0

    def describe(self) -> dict[str, Any]:
        out = self.params.model_dump(exclude={"grid"})
        grid = self.params.grid
        out.update(name=self.name, n_velocity=self.n,
                   grid=None if grid is None else f"{grid.nx}x{grid.nz}")
        return out

    # --- set-up ---------------------------------------------------------------------------------
    def _blocks(self, K: sp.csr_matrix) -> _Blocks:
        n = self.n
        if not n < K.shape[0]:
            raise GranflowInputError(f"amg solver: the matrix ({K.shape[0]} unknowns) has no block "
                                     f"after the {n} velocity unknowns")
        dA = K.diagonal()[:n]
        if np.any(dA <= 0):
            raise LinearSolverError("amg solver: the velocity block has a non-positive diagonal")
        Bu, Bl = K[:n, n:], K[n:, :n]
        s1 = K.diagonal()[n:] - np.asarray(Bl.multiply(Bu.T) @ (1.0 / dA)).ravel()
        s1 = np.abs(s1)
        s1 = np.where(s1 > TINY, s1, 1.0)
        d = 1.0 / np.sqrt(np.concatenate([dA, s1]))
        Ks = scale_symmetric(K, d)
        return _Blocks(K=Ks, A=Ks[:n, :n], Bu=Ks[:n, n:], Bl=Ks[n:, :n], Cb=Ks[n:, n:], d=d)

    def _schur(self, blk: _Blocks, kind: Schur, hints: SaddleHints | None, change: MatrixChange,
               aug: _Augmentation | None) -> tuple[Any, bool]:
        """The function ``r -> S^-1 r`` (scaled variables) and whether a hierarchy was rebuilt."""
        n = self.n
        theta = np.ones(blk.Cb.shape[0]) if aug is None else aug.theta
        if kind in (Schur.CAHOUET_CHABARD, Schur.AUGMENTED):
            w_inv = 1.0 / (self._mass(hints) * blk.d[:n] ** 2)
        else:
            w_inv = 1.0 / blk.A.diagonal()
        root = sp.diags(np.sqrt(theta))
        Bu = blk.Bu if aug is None else aug.Bu_scaled(blk.d, n)
        L = (blk.Cb - root @ blk.Bl @ sp.diags(w_inv) @ Bu @ root).tocsr()
        L.sort_indices()
        flip = np.where(L.diagonal() < 0, -1.0, 1.0)
        rebuilt = self.pressure.update((sp.diags(flip) @ L).tocsr(),
                                       same_values=change is MatrixChange.NONE)
        hier = self.pressure

        def l_inv(r):
            return hier.vcycle(flip * r)

        if kind is Schur.DIAGONAL:
            return l_inv, rebuilt
        if kind is Schur.LSC:
            W = sp.diags(w_inv)
            M = (blk.Cb - blk.Bl @ W @ blk.A @ W @ blk.Bu).tocsr()
            return (lambda r: l_inv(M @ l_inv(r))), rebuilt
        eta = self._viscosity(hints, L.shape[0])
        k = eta.size
        dp2 = blk.d[n:n + k] ** 2
        gamma = np.zeros(k) if aug is None else aug.gamma[:k]
        visc = np.zeros(L.shape[0])
        visc[:k] = flip[:k] / (np.abs(blk.Cb.diagonal()[:k]) + dp2 * theta[:k] / (eta + gamma))
        return (lambda r: l_inv(r) + visc * r), rebuilt

    def _mass(self, hints: SaddleHints | None) -> np.ndarray:
        if hints is None:
            raise GranflowInputError("amg solver: this Schur approximation needs SaddleHints")
        mass = np.asarray(hints.mass, dtype=float)
        if mass.shape != (self.n,) or np.any(~(mass > 0)):
            raise GranflowInputError(f"amg solver: hints.mass must be {self.n} positive values")
        return mass

    @staticmethod
    def _viscosity(hints: SaddleHints, m: int) -> np.ndarray:
        eta = np.asarray(hints.viscosity, dtype=float)
        if eta.ndim != 1 or eta.size > m or np.any(~np.isfinite(eta)) or np.any(eta <= 0):
            raise GranflowInputError("amg solver: hints.viscosity must hold positive values for at "
                                     f"most {m} pressure unknowns")
        return eta

    def _augment(self, K: sp.csr_matrix, b: np.ndarray, hints: SaddleHints) -> _Augmentation:
        """Augmented-Lagrangian form (module docstring, item 4): add ``B_u Gamma`` times the
        constraint rows to the momentum rows, ``Gamma = diag(eta/(1 + eta C))`` on the granular
        pressure rows (zero on trailing blocks). Same solution, stiffer velocity block."""
        n, m = self.n, K.shape[0] - self.n
        if hints is None:
            raise GranflowInputError("amg solver: schur='augmented' needs SaddleHints")
        eta = self._viscosity(hints, m)
        k = eta.size
        C = np.abs(K.diagonal()[n:n + k])
        gamma = np.zeros(m)
        gamma[:k] = eta / (1.0 + eta * C)
        theta = np.ones(m)
        theta[:k] = 1.0 / (1.0 + eta * C)
        Bu, Bl, Cb = K[:n, n:], K[n:, :n], K[n:, n:]
        G = sp.diags(gamma)
        # COO sums keep the explicit zeros of A (csr + csr would drop them), so that the
        # pattern -- and hence the reusable hierarchy -- does not depend on the active set.
        Ka = sp.bmat([[K[:n, :n], Bu], [Bl, Cb]], format="coo")
        extra = sp.bmat([[Bu @ G @ Bl, Bu @ G @ Cb], [None, sp.csr_matrix((m, m))]], format="coo")
        Ka = sp.coo_matrix((np.concatenate([Ka.data, extra.data]),
                            (np.concatenate([Ka.row, extra.row]), np.concatenate([Ka.col, extra.col]))),
                           shape=K.shape).tocsr()
        Ka.sum_duplicates()
        Ka.sort_indices()
        ba = b.copy()
        ba[:n] += Bu @ (gamma * b[n:])
        return _Augmentation(K=Ka, b=ba, gamma=gamma, theta=theta, Bu=Bu.tocsr())

    # --- solve ----------------------------------------------------------------------------------
    def solve(self, matrix, rhs, x0=None, change=MatrixChange.AUTO, hints: SaddleHints | None = None):
        """Solve the saddle-point system (see :meth:`LinearSolver.solve`); ``x0`` warm-starts
        FGMRES, ``hints`` enable the Cahouet-Chabard Schur approximation."""
        change = MatrixChange(change)
        K = canonical(matrix, "csr")
        b, x0 = check_system(K, rhs, x0)
        n = self.n
        t0 = time.perf_counter()
        if change is MatrixChange.PATTERN:
            self.velocity.stale = self.pressure.stale = True
        kind = self.params.schur
        if kind is Schur.AUTO:
            kind = Schur.LSC if hints is None else Schur.AUGMENTED
        aug = self._augment(K, b, hints) if kind is Schur.AUGMENTED else None
        blk = self._blocks(K if aug is None else aug.K)
        B = None if self.near_nullspace is None else self.near_nullspace / blk.d[:n, None]
        rebuilt = self.velocity.update(blk.A, B, same_values=change is MatrixChange.NONE)
        s_inv, rebuilt_p = self._schur(blk, kind, hints, change, aug)
        rebuilt = rebuilt or rebuilt_p
        vel = self.velocity

        def apply(r):
            zq = s_inv(r[n:])
            zu = vel.vcycle(r[:n] - blk.Bu @ zq)
            return np.concatenate([zu, zq])

        M = LinearOperator(K.shape, matvec=apply, dtype=float)
        t1 = time.perf_counter()
        bs = blk.d * (b if aug is None else aug.b)
        ys0 = None if x0 is None else x0 / blk.d
        history: list[float] = []
        restart = min(DEFAULT_RESTART, self.params.max_iterations)
        outer = -(-self.params.max_iterations // restart)
        import pyamg  # lazily (granflow.solvers.amg)

        ys, _ = pyamg.krylov.fgmres(blk.K, bs, x0=ys0, tol=self.params.rtol, restart=restart,
                                    maxiter=outer, M=M, residuals=history)
        t2 = time.perf_counter()
        x = blk.d * ys
        its = max(len(history) - 1, 0)
        scaled = relative_residual(blk.K, ys, bs)
        converged = bool(np.all(np.isfinite(x))) and scaled <= self.params.rtol * (1.0 + 1e-6)
        self._track(its, rebuilt)
        info = SolveInfo(solver=self.name, iterations=its, residual=relative_residual(K, x, b),
                         scaled_residual=scaled, setup_time=t1 - t0, solve_time=t2 - t1,
                         rebuilt=rebuilt, converged=converged)
        if not converged and self.params.raise_on_failure:
            raise LinearSolverError(f"amg solver: scaled relative residual {scaled:.3g} > rtol "
                                    f"{self.params.rtol:.3g} after {its} iterations")
        return x, info

    def _track(self, iterations: int, rebuilt: bool) -> None:
        """Mark the hierarchies stale when the iterations grew by ``rebuild_factor`` since the
        last full set-up (the next solve rebuilds them)."""
        if rebuilt or self._base_iterations == 0:
            self._base_iterations = max(iterations, 1)
        elif iterations > self.params.rebuild_factor * self._base_iterations:
            self.velocity.stale = self.pressure.stale = True
