"""The MKL side of :mod:`granflow.solvers.pardiso`: finding and loading the MKL runtime through
``pypardiso``, MKL's thread-local thread count, the symmetric storage (upper triangle) of a CSR
matrix and the raw PARDISO call. Split from :mod:`granflow.solvers.pardiso` to keep modules small;
everything here is private to it except :func:`pardiso_available`.
"""
from __future__ import annotations

import ctypes
import functools
import glob
import os
import sys

import numpy as np
import scipy.sparse as sp


_MKL_RT_VARIABLE = "PYPARDISO_MKL_RT"
"""pypardiso reads the path of MKL's runtime library from this environment variable; without it
every new solver searches ``sys.prefix`` with a recursive glob (0.5 s each, measured)."""


_MKL_RT_GLOBS = ("lib/libmkl_rt.so*", "lib/libmkl_rt*.dylib", "Library/bin/mkl_rt*.dll")
"""Where the ``mkl`` wheel puts the runtime under ``sys.prefix`` (looked at before pypardiso's
recursive search)."""


@functools.cache
def _mkl_runtime() -> str | None:
    """Path of the MKL runtime (searched once per process), or None if pypardiso or MKL is missing.

    ``import pypardiso`` builds a module-level solver, which searches ``sys.prefix`` recursively
    (0.8 s) unless the environment variable points at the runtime: it is set for the import."""
    quick = sorted((p for pat in _MKL_RT_GLOBS for p in glob.glob(os.path.join(sys.prefix, pat))), key=len)
    pypardiso = None
    for path in [*quick, None]:  # None: pypardiso's own search
        saved = os.environ.get(_MKL_RT_VARIABLE)
        if path is not None and saved is None:
            os.environ[_MKL_RT_VARIABLE] = path
        try:
            import pypardiso
            break
        except ModuleNotFoundError:  # pypardiso is not installed
            return None
        except Exception:  # its module-level solver found no loadable runtime with this path
            continue
        finally:
            if saved is None:
                os.environ.pop(_MKL_RT_VARIABLE, None)
    if pypardiso is None:
        return None
    for path in [*quick, None]:
        saved = os.environ.get(_MKL_RT_VARIABLE)
        if path is not None and saved is None:
            os.environ[_MKL_RT_VARIABLE] = path
        try:
            return str(pypardiso.PyPardisoSolver().libmkl._name)
        except Exception:  # this library does not load, or (path None) pypardiso finds none
            continue
        finally:
            if saved is None:
                os.environ.pop(_MKL_RT_VARIABLE, None)
    return None


def pardiso_available() -> bool:
    """True if ``pypardiso`` imports and finds the MKL runtime."""
    return _mkl_runtime() is not None


def _thread_local_setter(libmkl):
    """``MKL_Set_Num_Threads_Local`` of the loaded runtime (n > 0: this thread's MKL calls use n
    threads; 0: back to the global setting), or None if the runtime lacks it."""
    try:
        fn = libmkl.MKL_Set_Num_Threads_Local
    except AttributeError:
        return None
    fn.restype = ctypes.c_int
    fn.argtypes = [ctypes.c_int]
    return fn


def _new_pypardiso(mtype: int):
    """A ``pypardiso.PyPardisoSolver`` pointed at the runtime found by :func:`_mkl_runtime`
    (the environment variable is set only for the constructor and restored afterwards)."""
    import pypardiso

    saved = os.environ.get(_MKL_RT_VARIABLE)
    os.environ[_MKL_RT_VARIABLE] = saved or _mkl_runtime()
    try:
        return pypardiso.PyPardisoSolver(mtype=mtype)
    finally:
        if saved is None:
            del os.environ[_MKL_RT_VARIABLE]


def _transpose_permutation(A: sp.csr_matrix) -> np.ndarray | None:
    """For a CSR pattern (canonical) that equals its transpose's and stores every diagonal
    entry: the permutation ``t`` with ``A.T``'s CSR data ``= A.data[t]``, so that a matrix of
    that pattern is symmetric exactly when ``A.data[t] == A.data`` (one gather instead of a
    transposition per sweep); else None."""
    n = A.shape[0]
    T = sp.csr_matrix((np.arange(A.nnz, dtype=np.int64), A.indices, A.indptr), shape=A.shape).tocsc()
    if not (np.array_equal(T.indptr, A.indptr) and np.array_equal(T.indices, A.indices)):
        return None
    rows = np.repeat(np.arange(n), np.diff(A.indptr))
    if int(np.count_nonzero(A.indices == rows)) != n:
        return None
    return T.data


class _UpperTriangle:
    """The upper triangle (diagonal included) of a fixed CSR pattern: which entries, and its own
    CSR pattern, so that every matrix of the pattern gives the same triangle pattern (stored
    zeros kept, unlike ``scipy.sparse.triu``). :meth:`of_values` fills one CSR matrix kept per
    pattern, whose index arrays are private (never changed), with PARDISO's 1-based int32 copies
    made once (``one_based``; pypardiso's ``_call_pardiso`` makes them at every phase)."""

    def __init__(self, shape, keep: np.ndarray, indptr: np.ndarray, indices: np.ndarray) -> None:
        self.shape, self.keep, self.indptr, self.indices = shape, keep, indptr, indices
        self.matrix = sp.csr_matrix((np.zeros(keep.size), indices, indptr), shape=shape)
        self.one_based = (self.matrix.indptr.astype(np.int32) + 1, self.matrix.indices.astype(np.int32) + 1)

    @classmethod
    def of(cls, A: sp.csr_matrix) -> _UpperTriangle:
        n = A.shape[0]
        rows = np.repeat(np.arange(n), np.diff(A.indptr))
        up = A.indices >= rows
        indptr = np.concatenate([[0], np.cumsum(np.bincount(rows[up], minlength=n))])
        return cls(A.shape, np.flatnonzero(up), indptr, A.indices[up])

    def of_values(self, data: np.ndarray) -> sp.csr_matrix:
        self.matrix.data = data[self.keep]
        return self.matrix


def _pardiso_call(solver, A: sp.csr_matrix, b: np.ndarray, one_based=None) -> np.ndarray:
    """pypardiso's ``PyPardisoSolver._call_pardiso`` (0.4.x) with the 1-based int32 index arrays
    ``one_based = (ia, ja)`` of ``A`` given (made here if None): the same MKL ``pardiso`` call,
    arguments and error (``PyPardisoError``)."""
    from pypardiso.pardiso_wrapper import PyPardisoError

    ia, ja = one_based if one_based is not None else (A.indptr.astype(np.int32) + 1,
                                                      A.indices.astype(np.int32) + 1)
    x = np.zeros_like(b)
    err = ctypes.c_int32(0)
    int_p, float_p = ctypes.POINTER(ctypes.c_int32), ctypes.POINTER(ctypes.c_double)

    def int_ref(v: int):
        return ctypes.byref(ctypes.c_int32(v))

    solver._mkl_pardiso(solver.pt.ctypes.data_as(ctypes.POINTER(solver._pt_type[0])), int_ref(1), int_ref(1),
                        int_ref(solver.mtype), int_ref(solver.phase), int_ref(A.shape[0]),
                        A.data.ctypes.data_as(float_p), ia.ctypes.data_as(int_p), ja.ctypes.data_as(int_p),
                        solver.perm.ctypes.data_as(int_p), int_ref(1 if b.ndim == 1 else b.shape[1]),
                        solver.iparm.ctypes.data_as(int_p), int_ref(solver.msglvl),
                        b.ctypes.data_as(float_p), x.ctypes.data_as(float_p), ctypes.byref(err))
    if err.value != 0:
        raise PyPardisoError(err.value)
    return np.ascontiguousarray(x)
