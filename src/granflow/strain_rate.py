"""``|S|`` of :meth:`granflow.operators.Operators.strain_rate_norm` on the cells of a mask only,
0 elsewhere (the Picard sweeps need it where the closure is evaluated, the dense cells, a new
mask each step; in the plane and with the axisymmetric grid's rows,
:attr:`granflow.model.Model.strain_rows`).

:class:`StrainRate` keeps the whole operators' CSR arrays (the cell rows ``R_k``, ``en``,
``node_to_cell``), once per model; :meth:`StrainRate.on` takes a mask's cell list only, and the
compiled kernel (:mod:`granflow._strain_numba`, Numba) evaluates the rows of those cells
directly, each row's entries summed from 0 in their stored order as SciPy's sparse mat-vec does,
so the values equal the whole-grid operator's bit for bit (tests/unit/test_strain_rate.py,
tests/unit/test_operators.py). The NumPy reference :meth:`StrainRateOn.numpy` (used when Numba
does not import) slices the rows of the mask's cells and of the nodes they read, and takes the
sparse mat-vecs on them.

Why: the mask changes every step, and slicing the CSR rows per mask cost more than the calls of
the step. Measured at 256^2 (timeit, best of 7, shared 2-core host; set-up = a new mask, call =
one |S|, old = the rows sliced per mask and SciPy's mat-vecs on them)::

    cells of the mask        set-up old -> new     call old -> new
    plane,  7 % (a column)   0.29 -> 0.012 ms      0.048 -> 0.057 ms
    plane, 50 %              3.1  -> 0.029 ms      0.28  -> 0.31 ms
    axisymmetric, 7 %        0.43 -> 0.012 ms      0.072 -> 0.075 ms
    axisymmetric, 50 %       2.0  -> 0.029 ms      0.42  -> 0.47 ms

The kernel's index arrays are unsigned (Numba's indexing then has no negative-index wrap; its
CSR row sums were 2.5x slower with SciPy's int32 indices) and each node's ``(en u)^2`` is evaluated
once (with both undone the plane 7 % call took 0.26 ms).

Numba is imported on first use (``import granflow`` stays light); the compiled function is cached
on disk (``cache=True``).
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp

from granflow.physics.lazy_kernel import LazyKernel

if TYPE_CHECKING:
    from granflow.operators import Operators

_KERNEL = LazyKernel("granflow._strain_numba", "strain_rate_on")


def kernel_available() -> bool:
    """True if Numba imports (the compiled kernel is then used by :class:`StrainRateOn`); asked
    once."""
    return _KERNEL.available()


def _csr(a) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(indptr, indices, data)`` of ``a`` as CSR, the index arrays unsigned 64-bit (the kernel's
    indexing then has no negative-index wrap)."""
    m = sp.csr_matrix(a)
    return (m.indptr.astype(np.uint64), m.indices.astype(np.uint64),
            np.ascontiguousarray(m.data, dtype=np.float64))


class StrainRate:
    """The operators of ``|S|^2 = sum_k (R_k u)^2/4 + (node_to_cell (en u)^2)/4`` as whole CSR
    arrays, built once: ``rows`` the cell rows ``R_k`` (default ``(ops.ec,)``, the plane; the
    axisymmetric grid's three scaled pair rows, :attr:`granflow.model.Model.strain_rows`)."""

    def __init__(self, ops: Operators, rows=None) -> None:
        self.ops = ops
        self.source = rows
        self.rows = (ops.ec,) if rows is None else tuple(rows)
        n = ops.grid.n_cells
        parts = [sp.csr_matrix(r) for r in self.rows]
        if any(p.shape[0] != n for p in parts):
            raise ValueError(f"strain rows must have {n} rows (the cells)")
        # row k n_cells + c of the stacked rows is row c of R_k, its entries in their order
        offsets = np.cumsum([0] + [p.nnz for p in parts[:-1]])
        ptr = np.concatenate([parts[0].indptr[:1]] + [p.indptr[1:].astype(np.int64) + o
                                                      for p, o in zip(parts, offsets)])
        stacked = sp.csr_matrix((np.concatenate([p.data for p in parts]),
                                 np.concatenate([p.indices for p in parts]), ptr),
                                shape=(len(parts) * n, parts[0].shape[1]))
        self.arrays = ((np.uint64(n), np.uint64(len(parts))) + _csr(stacked) + _csr(ops.en)
                       + _csr(ops.node_to_cell))

    def on(self, cells) -> StrainRateOn:
        """``|S|`` on the cells of the bool mask ``cells`` (see :class:`StrainRateOn`)."""
        return StrainRateOn(self, cells)


class StrainRateOn:
    """``|S|`` of :meth:`Operators.strain_rate_norm` (or of :class:`StrainRate`'s rows) at the
    cells of a mask, 0 elsewhere, as a callable of the velocity; the values equal the
    whole-grid operator's bit for bit (module docstring)."""

    def __init__(self, rate: StrainRate, cells) -> None:
        mask = np.asarray(cells, dtype=bool).ravel()
        n_cells = rate.ops.grid.n_cells
        if mask.size != n_cells:  # the kernel does not check its indices
            raise ValueError(f"StrainRateOn: a mask of {mask.size} cells on a grid of {n_cells}")
        self.rate = rate
        self.cells = np.flatnonzero(mask)
        self._unsigned = self.cells.astype(np.uint64)
        self._sliced = None

    @classmethod
    def of(cls, ops: Operators, cells, rows=None) -> StrainRateOn:
        """``|S|`` on the cells of ``cells`` with the rows ``rows`` (default ``(ops.ec,)``); a new
        :class:`StrainRate` (use :meth:`StrainRate.on` to keep it across masks)."""
        return cls(StrainRate(ops, rows), cells)

    def __call__(self, vel) -> np.ndarray:
        vel = self.rate.ops._velocity(vel)
        if not kernel_available():
            return self.numpy(vel)
        return _KERNEL.get()(self._unsigned, np.ascontiguousarray(vel), *self.rate.arrays)

    def numpy(self, vel) -> np.ndarray:
        """The NumPy reference: the rows of ``R_k`` and ``node_to_cell`` of the mask's cells and
        the rows of ``en`` of the nodes they read, sliced on first use, and their sparse
        mat-vecs (each kept row holds the whole operator's entries in their order)."""
        from granflow.operators import sorted_unique

        ops = self.rate.ops
        vel = ops._velocity(vel)
        if self._sliced is None:
            cells = self.cells
            n2c = sp.csr_matrix(ops.node_to_cell)[cells]
            nodes = sorted_unique(n2c.indices)
            renum = np.zeros(ops.node_to_cell.shape[1], dtype=n2c.indices.dtype)
            renum[nodes] = np.arange(nodes.size)  # increasing: each row keeps its entry order
            n2c = sp.csr_matrix((n2c.data, renum[n2c.indices], n2c.indptr), shape=(cells.size, nodes.size))
            rows = tuple(sp.csr_matrix(r)[cells] for r in self.rate.rows)
            self._sliced = (rows, sp.csr_matrix(ops.en)[nodes], n2c)
        rows, en, n2c = self._sliced
        out = np.zeros(ops.grid.n_cells)
        diag = sum((r @ vel) ** 2 for r in rows)
        out[self.cells] = np.sqrt(0.25 * diag + 0.25 * (n2c @ (en @ vel) ** 2))
        return out
