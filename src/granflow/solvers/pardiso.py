"""Sparse LU by Intel MKL PARDISO (optional extra ``granflow[fast]``: the ``pypardiso`` wheel).

Why: on the saddle-point systems of the Picard sweeps (issue "performance" item 2) SciPy's
SuperLU refactorises from scratch at every sweep (310 ms at 128^2 in the Lagree column, 3.3e4
unknowns), while PARDISO splits the work into an analysis (fill-reducing ordering and symbolic
factorisation, phase 11), a numerical factorisation (phase 22) and the solve (phase 33), and the
analysis can be kept while the sparsity pattern does not change: the Picard sweeps of one step,
whose pattern the Model keeps fixed by pinning free cells instead of dropping them
(``SaddleAssembler.saddle(..., unknowns=dense)``). The analysis is redone at the first sweep of
each step (:meth:`PardisoSolver.begin_step`), because its scaling and matching depend on the
matrix values and a restarted run must be bit-identical to a continued one. Measured on that
system (one core): analysis 57 ms (minimum degree) / 132 ms (METIS), numerical factorisation
80-90 ms, solve 6 ms (benchmarks/linear_solvers.py, benchmarks/README.md).

Interface: :class:`PardisoSolver` is the registry's ``"pardiso"``; :func:`pardiso_available`
says whether the MKL runtime can be loaded. The matrix is passed as CSR with sorted indices: its
upper triangle as real symmetric indefinite (type -2) when it is exactly symmetric with a stored
diagonal (the Model's saddle systems; ~2x cheaper factorisation), else whole as real unsymmetric
(type 11); scaling and weighted matching on. Systems below ``threaded_min_unknowns`` run on one
thread (MKL's threads lose there, and collapse when another process shares the cores); the
threaded ones use MKL's reproducibility mode. The result does not depend on the number of MKL
threads (tests/integration/test_pardiso.py).

Note: PARDISO's phases are reached through ``pypardiso.PyPardisoSolver._call_pardiso`` (its
public ``solve`` always re-analyses a new matrix), hence the pin ``pypardiso < 0.5``.
"""
from __future__ import annotations

import time
from enum import Enum
from typing import Any, Mapping

import numpy as np
import scipy.sparse as sp
from pydantic import Field

from granflow.errors import GranflowInputError
from granflow.params import Params
from granflow.solvers.linear import (LINEAR_SOLVERS, LinearSolver, LinearSolverError, MatrixChange,
                                     SolveInfo, check_system, relative_residual,
                                     residual_and_error)
from granflow.solvers.pardiso_mkl import (_new_pypardiso, _pardiso_call, _thread_local_setter,  # noqa: F401
                                          _transpose_permutation, _UpperTriangle, pardiso_available)


class PardisoPhase(int, Enum):
    """PARDISO phase codes (MKL reference, ``pardiso`` ``phase`` argument)."""

    ANALYSIS = 11
    FACTORISE = 22
    SOLVE = 33
    ANALYSE_FACTORISE_SOLVE = 13
    RELEASE = -1


class PardisoOrdering(str, Enum):
    """Fill-reducing ordering of the analysis (``iparm[2]``)."""

    MINIMUM_DEGREE = "minimum_degree"
    METIS = "metis"


_ORDERING_IPARM = {PardisoOrdering.MINIMUM_DEGREE: 0, PardisoOrdering.METIS: 2}
class MatrixType(int, Enum):
    """PARDISO matrix types (``mtype``) used here."""

    UNSYMMETRIC = 11
    """Real unsymmetric: any matrix (the full CSR is passed)."""
    SYMMETRIC_INDEFINITE = -2
    """Real symmetric indefinite: the upper triangle is passed. Used when the matrix is exactly
    symmetric with every diagonal entry stored (the saddle systems of the Model, whose gas rows
    are scaled to keep the symmetry): on the banded Lagree systems its factorisation is 1.8x
    (2.7e3 unknowns) to 2x (1.1e4) faster than type 11, measured on one thread."""


_IPARM_USER = 1
"""iparm(1) = 1: the iparm array is filled by the caller."""
SYMMETRIC_PIVOT_PERTURBATION = 6
"""iparm(10) of the symmetric type: tiny pivots are perturbed to ``1e-6 |A|`` (MKL's default is 8,
``1e-8``). With the analysis kept across steps (:attr:`PardisoSolver.Parameters.analysis_steps`)
the scaling and matching come from an earlier matrix and most factorisations perturb some
pivots; MKL then refines the solution twice. Measured on the Lagree column to t = 4
(benchmarks/README.md, session 27): relative residuals median 9.5e-11 / max 4.8e-10 at 128^2 and
3.1e-9 / 1.0e-8 at 256^2 (the :data:`RESIDUAL_LIMIT`: 5 reanalyses) with 1e-8, against 1.1e-14 /
5.1e-14 and 3.3e-13 / 1.3e-12 with 1e-6, at the same PARDISO time; 1e-10 (iparm(10) = 10) puts
most kept-analysis solves above the limit (~400 reanalyses at 128^2)."""
_IPARM_SETTINGS = {
    MatrixType.UNSYMMETRIC: {1: _IPARM_USER, 10: 13, 11: 1, 13: 1},
    MatrixType.SYMMETRIC_INDEFINITE: {1: _IPARM_USER, 10: SYMMETRIC_PIVOT_PERTURBATION, 11: 1, 13: 1, 21: 1},
}
"""1-based iparm entries set per matrix type: MKL's documented defaults (10: pivot perturbation
1e-13 for the unsymmetric type; 21 = 1 for the symmetric type: Bunch-Kaufman 1x1 and 2x2 pivots)
but the symmetric type's perturbation (:data:`SYMMETRIC_PIVOT_PERTURBATION`), with scaling and
weighted matching on (11 = 13 = 1; MKL recommends them for saddle-point symmetric indefinite
systems, whose residual is 1e-10 without them). iparm(8), the iterative refinement, is
:attr:`PardisoSolver.Parameters.refinement_steps`."""
_IPARM_REFINEMENT = 8
"""1-based iparm entry of the maximum number of iterative refinement steps."""
MAX_REFINEMENT_STEPS = 10
"""Upper bound of :attr:`PardisoSolver.Parameters.refinement_steps` (a sanity bound)."""
DEFAULT_REFINEMENT_STEPS = 0
"""iparm(8) by default (:attr:`PardisoSolver.Parameters.refinement_steps`): MKL's default, which
refines (two steps) only after perturbed pivots. Measured on the Lagree column at 128^2 to t = 4
(1411 solves, no perturbed pivot): relative residual <= 2.9e-14 without refinement (median
6.6e-16) and the same steps, sweeps and fronts as with two steps (the earlier setting, which did
both steps at every solve), with the solve phase 1.13 -> 0.63 ms (benchmarks/README.md, issue 15)."""
DEFAULT_REPRODUCIBLE_THREADS = 4
"""iparm(34) by default (:attr:`PardisoSolver.Parameters.reproducible_threads`)."""
DEFAULT_THREADED_MIN_UNKNOWNS = 100_000
"""Systems with fewer unknowns are solved on one thread by default
(:attr:`PardisoSolver.Parameters.threaded_min_unknowns`). Measured on the 2-core machine: the
banded Lagree systems (2.7e3 unknowns) factorise in 3.1 ms on one thread and 3.5 ms on two, and
in 110 ms on two when another process runs on the second core (MKL's threads wait for the busy
core); at 3.3e4 unknowns two threads gain ~15 %."""
_EMPTY_MATRIX = sp.csr_matrix((0, 0))
_EMPTY_RHS = np.zeros(0)
"""Arguments of the release phase, built once (``__del__`` may run at interpreter shutdown)."""
RESIDUAL_LIMIT = 1.0e-8
"""A PARDISO solution whose relative residual |Ax - b|/|b| exceeds this is not accepted: PARDISO
perturbs tiny pivots instead of failing on a (nearly) singular matrix. The system is then solved
again by SciPy's SuperLU (:attr:`PardisoSolver.fallbacks` counts it), which raises if the matrix is
singular. Found on a prepared (gas-injected) column at the release step, where PARDISO's residual
was 1.4e-8 at every dt (the run failed before the fallback existed)."""
FALLBACK_RESIDUAL_LIMIT = 1.0e-6
"""The SuperLU fallback's solution must reach this relative residual, or the solve is an error."""
ANALYSIS_KEYS = ("analysis.indptr", "analysis.indices", "analysis.data")
"""Checkpoint arrays of a kept analysis (:meth:`PardisoSolver.checkpoint_payload`): its matrix, CSR."""
KEPT_STEPS_KEY = "analysis.kept_steps"
"""Checkpoint scalar: steps begun since that analysis (:meth:`PardisoSolver.begin_step`)."""


@LINEAR_SOLVERS.register("pardiso")
class PardisoSolver(LinearSolver):
    """Sparse LU by MKL PARDISO with the analysis kept across matrices of the same pattern.

    ``solve`` re-uses the factorisation when the matrix is unchanged (``change="none"``, or
    ``"auto"`` with equal pattern and values), re-factorises numerically (phase 22) when only the
    values changed, and re-analyses (phases 11 + 22) when the pattern changed.
    ``SolveInfo.rebuilt`` is True when the analysis was redone; ``setup_time`` covers analysis and
    factorisation. Counters: :attr:`analyses`, :attr:`factorisations`, :attr:`fallbacks` (solves
    redone by SuperLU because PARDISO's residual exceeded :data:`RESIDUAL_LIMIT`).
    """

    class Parameters(Params):
        """Parameters of the PARDISO solver.

        Attributes
        ----------
        ordering : str
            Fill-reducing ordering of the analysis: ``"minimum_degree"`` (default: its analysis
            is 2x cheaper on the 2-D saddle systems and the factorisation only ~10 % dearer) or
            ``"metis"`` (nested dissection).
        reproducible_threads : int
            MKL's conditional numerical reproducibility (``iparm[33]``) for the threaded systems:
            with a value > 0 the result is bit-for-bit the same for every thread count
            (``MKL_NUM_THREADS``) up to it (measured: 1, 2, 3 threads with 4,
            tests/integration/test_pardiso.py), so a run and its restart agree on machines with other core
            counts. Default 4; 0 = off. Costs ~15 % at 3e4 unknowns and ~40 % of analysis and
            solve at 3e3, which is why the single-threaded systems do without it (one thread is
            reproducible by construction).
        threaded_min_unknowns : int
            Systems smaller than this are solved on one thread (MKL's thread-local setting,
            whatever ``MKL_NUM_THREADS`` says); larger ones use MKL's threads. Default
            :data:`DEFAULT_THREADED_MIN_UNKNOWNS`; 0 = always threaded.
        refinement_steps : int
            Maximum iterative refinement steps of each solve (``iparm[7]``). Default
            :data:`DEFAULT_REFINEMENT_STEPS` = 0: MKL refines (two steps) only after perturbed
            pivots; n > 0 refines up to n steps at every solve. Either way a solution whose
            relative residual exceeds :data:`RESIDUAL_LIMIT` is redone by SuperLU.
        analysis_steps : int
            Steps (:meth:`begin_step` calls) over which an analysis of an unchanged pattern is
            kept. Default 1: a fresh analysis every step. With n > 1 the scaling and matching of
            an earlier step's matrix are reused (a solve whose residual then exceeds
            :data:`RESIDUAL_LIMIT` is first redone with a fresh analysis); :meth:`forget` ends the
            window (a checkpoint calls it, so that a restart and the continued run agree bit for
            bit). Such solves leave relative residuals up to ~1e-12 with
            :data:`SYMMETRIC_PIVOT_PERTURBATION` (~1e-8 with MKL's default; 1e-15 with a fresh
            analysis; MKL's perturbed pivots); they are not refined (up to session 25 one
            refinement solve a step brought them to 1e-13, ~9 % of a 128² run): the energy budget
            books the solve's error instead (``linear_solve``, :class:`granflow.diagnostics.EnergyBudget`).
        """

        ordering: PardisoOrdering = Field(PardisoOrdering.MINIMUM_DEGREE,
                                          description="fill-reducing ordering of the analysis")
        reproducible_threads: int = Field(DEFAULT_REPRODUCIBLE_THREADS, ge=0, le=1024,
                                          description="MKL CNR mode thread count (0 = off)")
        threaded_min_unknowns: int = Field(DEFAULT_THREADED_MIN_UNKNOWNS, ge=0,
                                           description="smaller systems run on one thread")
        refinement_steps: int = Field(DEFAULT_REFINEMENT_STEPS, ge=0, le=MAX_REFINEMENT_STEPS,
                                      description="maximum iterative refinement steps per solve")
        analysis_steps: int = Field(1, ge=1, le=1_000_000, description="steps an analysis is kept "
                                    "while the pattern is unchanged")

    def __init__(self, params: Params) -> None:
        super().__init__(params)
        if not pardiso_available():
            raise LinearSolverError("linear solver 'pardiso' needs the optional dependency pypardiso with "
                                    "Intel MKL: pip install 'granflow[fast]' (x86-64 only); or use 'direct'")
        self._solver = None
        self._allocated = False
        self.reset()

    def reset(self) -> None:
        self._release()
        self._solver = _new_pypardiso(MatrixType.UNSYMMETRIC)
        self._set_type(MatrixType.UNSYMMETRIC)
        self._single_thread = False
        """The current matrix is solved on one thread (decided at its analysis)."""
        self._upper: _UpperTriangle | None = None
        """Upper triangle of the current pattern when it is solved as symmetric."""
        self._transpose: np.ndarray | None = None
        """:func:`_transpose_permutation` of the current pattern (symmetric type only)."""
        self._pattern: tuple[np.ndarray, np.ndarray] | None = None
        self._data: np.ndarray | None = None
        self._analysed: np.ndarray | None = None
        """Values of the analysed matrix, kept only with ``analysis_steps > 1`` (for checkpoints)."""
        self.analyses = 0
        self.factorisations = 0
        self.fallbacks = 0
        self._kept_steps = 0
        """Steps begun since the analysis was last forgotten."""
        self.reanalyses = 0
        """Solves redone with a fresh analysis after a kept one left a residual > RESIDUAL_LIMIT."""

    def _set_type(self, mtype: MatrixType) -> None:
        """Matrix type and its iparm settings (the handle holds no factorisation)."""
        self._solver.mtype = int(mtype)
        self._solver.iparm[:] = 0
        for i, v in _IPARM_SETTINGS[mtype].items():
            self._solver.set_iparm(i, v)
        self._solver.set_iparm(2, _ORDERING_IPARM[PardisoOrdering(self.params.ordering)])
        self._solver.set_iparm(_IPARM_REFINEMENT, int(self.params.refinement_steps))
        self._solver.set_iparm(34, int(self.params.reproducible_threads))

    @property
    def matrix_type(self) -> MatrixType:
        """Matrix type of the current factorisation."""
        return MatrixType(self._solver.mtype)

    def begin_step(self) -> None:
        """Forget the analysis every :attr:`Parameters.analysis_steps` steps (default: every step;
        the memory is kept until the next one replaces it): its scaling and matching (iparm[11],
        iparm[13]) are computed from the values of the matrix it analysed, so re-using it across
        steps makes a step depend on the steps before it (:meth:`forget` bounds that)."""
        self._kept_steps += 1
        if self._kept_steps >= self.params.analysis_steps:
            self.forget()

    def forget(self) -> None:
        """Drop the analysis now: the next solve analyses afresh."""
        self._pattern = None
        self._data = None
        self._analysed = None
        self._kept_steps = 0

    def _call(self, phase: PardisoPhase, A: sp.csr_matrix, b: np.ndarray) -> np.ndarray:
        self._solver.set_phase(int(phase))
        local = _thread_local_setter(self._solver.libmkl) if self._single_thread else None
        # every phase of a handle must run on the thread count of its analysis (MKL crashes or
        # returns garbage otherwise): restore the previous setting, not the global one, since a
        # garbage-collected solver can release its memory from inside another one's call
        previous = local(1) if local is not None else None
        try:
            upper = getattr(self, "_upper", None)
            own = upper is not None and A is upper.matrix  # its 1-based arrays are kept
            return _pardiso_call(self._solver, A, b, upper.one_based if own else None)
        except Exception as err:  # pypardiso.PyPardisoError carries MKL's error code
            raise LinearSolverError(f"pardiso phase {int(phase)}: {err}") from err
        finally:
            if local is not None:
                local(previous)

    def _release(self) -> None:
        """Free MKL's memory of this handle (phase -1) if anything was allocated."""
        if not getattr(self, "_allocated", False) or getattr(self, "_solver", None) is None:
            return
        self._allocated = False
        self._pattern, self._data = None, None
        try:
            self._call(PardisoPhase.RELEASE, _EMPTY_MATRIX, _EMPTY_RHS)
        except Exception:  # nothing more can be done; MKL frees it at exit
            pass

    def __del__(self) -> None:  # MKL keeps the factors outside Python's heap
        try:
            self._release()
        except Exception:  # interpreter shutdown
            pass

    def solve(self, matrix, rhs, x0=None, change=MatrixChange.AUTO, hints=None):
        change = MatrixChange(change)
        A = sp.csr_matrix(matrix, dtype=np.float64)
        A.sum_duplicates()
        A.sort_indices()
        b, _ = check_system(A, rhs)
        b = np.ascontiguousarray(b, dtype=np.float64)
        t0 = time.perf_counter()
        same_pattern = (self._pattern is not None and A.shape[0] == self._pattern[0].size - 1
                        and np.array_equal(A.indptr, self._pattern[0])
                        and np.array_equal(A.indices, self._pattern[1]))
        same_values = same_pattern and self._data is not None and (
            change is MatrixChange.NONE or (change is MatrixChange.AUTO and np.array_equal(A.data, self._data)))
        if (same_pattern and not same_values and self._upper is not None
                and not np.array_equal(A.data[self._transpose], A.data)):
            same_pattern = False  # new values are not symmetric: analyse again as unsymmetric
        analysed = not same_pattern
        if analysed:
            self._analyse(A)
        M = self._stored(A)
        if not same_values:
            self._data = None
            self._call(PardisoPhase.FACTORISE, M, np.zeros(A.shape[0]))
            self._data = A.data.copy()
            self.factorisations += 1
        t1 = time.perf_counter()
        x = self._call(PardisoPhase.SOLVE, M, b)
        t2 = time.perf_counter()
        if not np.all(np.isfinite(x)):
            raise LinearSolverError("pardiso: non-finite solution (singular matrix?)")
        res, error = residual_and_error(A, x, b)
        if not res <= RESIDUAL_LIMIT and not analysed and self.params.analysis_steps > 1:
            self.reanalyses += 1  # a kept analysis: analyse this matrix afresh first
            self.forget()
            return self.solve(matrix, rhs, x0, MatrixChange.AUTO, hints)
        if not res <= RESIDUAL_LIMIT:
            x, res = self._fallback(A, b, res)
            error = None
            t2 = time.perf_counter()
        return x, SolveInfo(solver=self.name, iterations=0, residual=res, scaled_residual=res,
                            setup_time=t1 - t0, solve_time=t2 - t1, rebuilt=analysed, error=error)

    def _analyse(self, A: sp.csr_matrix) -> None:
        """Phase 11 on ``A`` (CSR, sorted indices): symmetric type if ``A`` is exactly symmetric."""
        self._pattern, self._data, self._analysed = None, None, None  # valid again once the phase succeeds
        self._transpose = _transpose_permutation(A)
        if self._transpose is not None and not np.array_equal(A.data[self._transpose], A.data):
            self._transpose = None
        self._upper = None if self._transpose is None else _UpperTriangle.of(A)
        mtype = MatrixType.UNSYMMETRIC if self._upper is None else MatrixType.SYMMETRIC_INDEFINITE
        if mtype is not self.matrix_type:
            self._release()
            self._set_type(mtype)
        self._allocated = True
        # one thread needs MKL's thread-local setter; without it keep the reproducibility mode
        self._single_thread = (A.shape[0] < self.params.threaded_min_unknowns
                               and _thread_local_setter(self._solver.libmkl) is not None)
        self._solver.set_iparm(34, 0 if self._single_thread else int(self.params.reproducible_threads))
        self._call(PardisoPhase.ANALYSIS, self._stored(A), np.zeros(A.shape[0]))
        self._pattern = (A.indptr.copy(), A.indices.copy())
        self._analysed = A.data.copy() if self.params.analysis_steps > 1 else None
        self.analyses += 1
        self._kept_steps = 0  # the window counts from the analysis

    def checkpoint_payload(self) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """The matrix of a kept analysis (``analysis_steps > 1``; :data:`ANALYSIS_KEYS`) and the
        steps since it, so that :meth:`restore_checkpoint` analyses the same matrix again and the
        restarted run factorises its next matrices as the continued one does, bit for bit."""
        if self._pattern is None or self._analysed is None:
            return {}, {}
        return (dict(zip(ANALYSIS_KEYS, (*self._pattern, self._analysed))),
                {KEPT_STEPS_KEY: int(self._kept_steps)})

    def restore_checkpoint(self, arrays: Mapping[str, Any], scalars: Mapping[str, Any]) -> None:
        """Analyse the matrix of a :meth:`checkpoint_payload` again (nothing if it holds none).

        Raises
        ------
        GranflowInputError
            If the stored matrix is not a square CSR matrix or its step count is not an integer.
        """
        self.forget()
        if self.params.analysis_steps <= 1 or not all(k in arrays for k in ANALYSIS_KEYS):
            return
        indptr, indices, data = (np.asarray(arrays[k]) for k in ANALYSIS_KEYS)
        kept = scalars.get(KEPT_STEPS_KEY)
        n = indptr.size - 1
        if (indptr.dtype.kind not in "iu" or indices.dtype.kind not in "iu" or data.dtype.kind != "f"
                or n < 1 or indices.size != data.size or indptr[0] != 0 or indptr[-1] != data.size
                or np.any(np.diff(indptr) < 0) or (indices.size and not 0 <= indices.min() <= indices.max() < n)
                or isinstance(kept, bool) or not isinstance(kept, int) or kept < 0):
            raise GranflowInputError(f"checkpoint: {', '.join(ANALYSIS_KEYS)} and {KEPT_STEPS_KEY} are not a "
                                    "square CSR matrix and a step count")
        A = sp.csr_matrix((data.astype(np.float64), indices, indptr), shape=(n, n))
        A.sort_indices()
        self._analyse(A)
        self._kept_steps = kept

    def _stored(self, A: sp.csr_matrix) -> sp.csr_matrix:
        """What PARDISO is given: ``A``, or its upper triangle for the symmetric type."""
        return A if self._upper is None else self._upper.of_values(A.data)

    def _fallback(self, A: sp.csr_matrix, b: np.ndarray, res_pardiso: float) -> tuple[np.ndarray, float]:
        """SuperLU on a system PARDISO solved inaccurately (see :data:`RESIDUAL_LIMIT`)."""
        import scipy.sparse.linalg as spla

        self.fallbacks += 1
        try:
            x = spla.splu(A.tocsc()).solve(b)
        except RuntimeError as err:  # "Factor is exactly singular"
            raise LinearSolverError(f"pardiso: relative residual {res_pardiso:.3g} > {RESIDUAL_LIMIT:g}, and "
                                    f"SuperLU: {err} (singular matrix?)") from err
        res = relative_residual(A, x, b)
        if not (np.all(np.isfinite(x)) and res <= FALLBACK_RESIDUAL_LIMIT):
            raise LinearSolverError(f"pardiso: relative residual {res_pardiso:.3g} > {RESIDUAL_LIMIT:g}, SuperLU "
                                    f"{res:.3g} > {FALLBACK_RESIDUAL_LIMIT:g} (singular matrix?)")
        return x, res
