"""Linear solvers with one interface, in a registry (issue "solver" item 8, NUMERICS.md §3.1, §12).

>>> from granflow.solvers import LINEAR_SOLVERS
>>> LINEAR_SOLVERS.names()
['amg', 'amg_cg', 'direct', 'pardiso']

``make_linear_solver(name, **params).solve(matrix, rhs, x0=None, change="auto", hints=None)``
returns ``(x, SolveInfo)``; see :mod:`granflow.solvers.linear` and :mod:`granflow.solvers.saddle`.
"""
from granflow.solvers.amg import Reuse, velocity_near_nullspace
from granflow.solvers.linear import (LINEAR_SOLVERS, AMGConjugateGradient, DirectSolver,
                                     LinearSolver, LinearSolverError, MatrixChange, SolveInfo,
                                     make_linear_solver)
from granflow.solvers.pardiso import PardisoSolver, pardiso_available
from granflow.solvers.saddle import BlockAMGSolver, SaddleHints, Schur

__all__ = [
    "AMGConjugateGradient",
    "BlockAMGSolver",
    "DirectSolver",
    "LINEAR_SOLVERS",
    "LinearSolver",
    "LinearSolverError",
    "MatrixChange",
    "PardisoSolver",
    "Reuse",
    "SaddleHints",
    "Schur",
    "SolveInfo",
    "make_linear_solver",
    "pardiso_available",
    "velocity_near_nullspace",
]
