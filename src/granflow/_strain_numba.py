"""The Numba function of :mod:`granflow.strain_rate` (imported on first use, so that
``import granflow`` does not import Numba; module-level so that ``cache=True`` can store it).
It mirrors the sparse mat-vecs of :meth:`granflow.strain_rate.StrainRateOn.numpy`: each row's
entries are summed from 0 in their stored order (SciPy's ``csr_matvec``), so the values are the
same bit for bit. The index arrays are unsigned (:class:`granflow.strain_rate.StrainRate`): Numba
then indexes without the negative-index wrap, as fast as SciPy's loop (2.5x slower signed)."""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _row_dot(indptr, indices, data, row, vel):
    """``(A @ vel)[row]`` of the CSR matrix ``(data, indices, indptr)``, in SciPy's order."""
    s = 0.0
    for jj in range(indptr[row], indptr[row + np.uint64(1)]):
        s += data[jj] * vel[indices[jj]]
    return s


@njit(cache=True)
def strain_rate_on(cells, vel, n_cells, n_rows, r_ptr, r_idx, r_val, e_ptr, e_idx, e_val, m_ptr,
                   m_idx, m_val):
    """``|S| = sqrt(sum_k (R_k u)^2/4 + (N (en u)^2)/4)`` at ``cells``, 0 elsewhere, shape
    ``(n_cells,)``: ``R_k`` row ``k n_cells + c`` of the stacked rows ``r``, ``en`` the node rows
    ``e``, ``N`` the node-to-cell mean ``m``. Each node's ``(en u)^2`` is evaluated once, where a
    cell first reads it."""
    out = np.zeros(np.int64(n_cells))
    n_nodes = e_ptr.size - 1
    q = np.empty(n_nodes)
    done = np.zeros(n_nodes, dtype=np.bool_)
    for k in range(cells.size):
        c = cells[k]
        diag = 0.0
        for r in range(n_rows):
            v = _row_dot(r_ptr, r_idx, r_val, r * n_cells + c, vel)
            diag += v * v
        shear = 0.0
        for jj in range(m_ptr[c], m_ptr[c + np.uint64(1)]):
            node = m_idx[jj]
            if not done[node]:
                e = _row_dot(e_ptr, e_idx, e_val, node, vel)
                q[node] = e * e
                done[node] = True
            shear += m_val[jj] * q[node]
        out[c] = np.sqrt(0.25 * diag + 0.25 * shear)
    return out
