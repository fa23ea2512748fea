"""Momentum balance of the solids, paper eq. syst3b, semi-discretised on the MAC grid
(NUMERICS.md §2, §3.1, §7):

    phi rho_s (d_t u + u . grad u) = phi rho_s g - grad p + div(2 eta S) [- grad p_f]

Time discretisation of one step (backward Euler for everything but advection):

    rho_f (u^{n+1} - u^n)/dt + rho_f a^n + V(eta) u^{n+1} + Grad p^{n+1} = f_g

* ``rho_f = max(phi_f rho_s, rho_a)`` at faces (``phi_f`` the centred mean of the two cells): the
  pressureless light ambient keeps the mass matrix positive where phi -> 0 (NUMERICS.md §7);
* ``f_g = phi_f rho_s g``: gravity acts on the grains only -- the ambient has no weight
  (``phi_f`` centred, or the mass-flux face fraction for energy-consistent gravity);
* ``a^n = (u^n . grad) u^n``: explicit, first-order upwind (v1, NUMERICS.md §3.1; the main source
  of numerical dissipation, §9) or MUSCL-minmod (:class:`Advection`);
* ``V(eta) = ec^T diag(eta_c) ec + en^T diag(w_n eta_n) en`` (:meth:`Operators.viscous_operator`),
  ``V u ~ -div(2 eta S)``; the regularised yield viscosity of :func:`yield_viscosity` is lagged in
  the Picard loop of :class:`granflow.model.Model`.

The (u, p) saddle-point matrix (:class:`SaddleAssembler`) is the symmetric form of
NUMERICS.md §3.1 restricted to the *active* cells (ambient and free cells have ``p = 0`` and are
not unknowns):

    [ A           Grad_act   ] [u    ]   [ r_u    ]
    [ Grad_act^T  -diag(C)   ] [p_act] = [ -b_act ]

with ``A = diag(rho_f/dt) + V`` and ``Grad^T = -Div``, so each row of the second block reads
``Div u + C p = b`` (the linearised dilatancy law). The pore-pressure block (paper eq. syst2b,
:mod:`granflow.physics.coupling`) is a third block row and column on the *wet* cells
(:class:`GasBorder`, NUMERICS.md §3.1):

    [ A           Grad_act   Grad_wet  ] [u     ]   [ r_u            ]
    [ Grad_act^T  -diag(C)   0         ] [p_act ] = [ -b_act         ]
    [ Grad_wet^T  0          -M/p_atm  ] [p_wet ]   [ -r_gas/p_atm   ]

i.e. the momentum rows get the full ``Grad p_f`` (paper eq. syst3b) and the gas rows
``M p_f + p_atm Div u = r_gas``, multiplied by ``-1/p_atm`` so that the whole matrix stays
symmetric (Biot-type structure; ``M`` is symmetric for both gas laws).
"""
from __future__ import annotations

from dataclasses import dataclass
from enum import Enum
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp

from granflow.errors import GranflowInputError
from granflow.grid import Grid, Side
from granflow.operators import GHOST_SIGN, Operators, product_pairs, sorted_unique

QUARTER = 0.25
HALF = 0.5


def face_density(ops: Operators, phi, rho_s: float, rho_a: float) -> np.ndarray:
    """Inertia ``rho_f = max(phi_f rho_s, rho_a)`` at the velocity unknowns [kg m^-3]."""
    return np.maximum(ops.cell_to_face @ np.ravel(phi) * rho_s, rho_a)


class Advection(str, Enum):
    """Spatial scheme of the explicit momentum advection ``(u . grad) u``."""

    UPWIND = "upwind"
    """First-order upwind differences (NUMERICS.md §3.1 v1)."""
    MUSCL = "muscl"
    """Upwind differences of MUSCL-minmod reconstructed mid-point values (second order away from
    extrema, TVD in 1-D for CFL <= 1/2)."""
    CONSISTENT = "consistent"
    """Conservative momentum transport with the phi transport's own mass fluxes and MUSCL-minmod
    face values (scheme v2, :mod:`granflow.physics.momentum_transport`); inertia
    ``rho_s phi_f + rho_a``."""


def _minmod(a, b):
    return np.where(a * b > 0.0, np.sign(a) * np.minimum(np.abs(a), np.abs(b)), 0.0)


def _pad(q, axis: int, low, high):
    """``q`` with two ghost layers on each side of ``axis``: ``low = (outer, inner)``,
    ``high = (inner, outer)``."""
    return np.concatenate([low[0], low[1], q, high[0], high[1]], axis=axis)


def _derivative(qp: np.ndarray, speed: np.ndarray, h: float, axis: int, scheme: Advection):
    """``speed * dq/dx`` at the interior points of the padded ``qp`` (2 ghosts per side)."""
    qp = np.moveaxis(qp, axis, 0)
    speed = np.moveaxis(speed, axis, 0)
    q = qp[2:-2]
    if scheme is Advection.UPWIND:
        back, fwd = (q - qp[1:-3]) / h, (qp[3:-1] - q) / h
    else:
        d = np.diff(qp, axis=0)                       # d[k] = qp[k+1] - qp[k]
        slope = _minmod(d[:-1], d[1:])                # at padded points 1 .. n+2
        face = qp[1:-1] + HALF * slope                # value at k+1/2 from point k (upwind u > 0)
        face_m = qp[1:-1] - HALF * slope              # value at k-1/2 from point k (upwind u < 0)
        back = (face[1:-1] - face[:-2]) / h           # (q_{i+1/2}^- - q_{i-1/2}^-) / h
        fwd = (face_m[2:] - face_m[1:-1]) / h         # (q_{i+1/2}^+ - q_{i-1/2}^+) / h
    out = np.where(speed > 0.0, speed * back, speed * fwd)
    return np.moveaxis(out, 0, axis)


def momentum_advection(ops: Operators, vel, scheme: Advection | str = Advection.UPWIND) -> np.ndarray:
    """Explicit ``(u . grad) u`` at the velocity unknowns [m s^-2] (NUMERICS.md §3.1, §9).

    The transverse velocity is the mean of the four surrounding staggered values. Ghost values:
    the normal velocity is odd about its wall (zero on it), the tangential velocity takes the
    wall condition's ghost (``-u`` no-slip, ``+u`` free-slip,
    :data:`granflow.operators.GHOST_SIGN`), mirrored for the second layer. Periodic in x
    (``grid.periodic_x``): the x stencils wrap instead (two periodic ghost columns).
    """
    scheme = Advection(scheme)
    g: Grid = ops.grid
    u, w = g.unpack_velocity(vel)
    sign = {side: GHOST_SIGN[ops.bcs.kind(side)] for side in Side}
    U, W = u[g.u_columns, :], w[:, 1:-1]
    # u at the x-face unknowns: along x (normal, odd about the walls), along z (tangential).
    if g.periodic_x:
        upx = _pad(U, 0, (U[-2:-1], U[-1:]), (U[:1], U[1:2]))
        wx = np.concatenate([w[-1:], w], axis=0)   # cells i-1, i either side of x-face i
    else:
        zx = np.zeros((1, g.nz))
        upx = _pad(U, 0, (-U[:1], zx), (zx, -U[-1:]))
        wx = w
    ax = _derivative(upx, U, g.dx, 0, scheme)
    sb, st = sign[Side.BOTTOM], sign[Side.TOP]
    upz = _pad(U, 1, (sb * U[:, 1:2], sb * U[:, :1]), (st * U[:, -1:], st * U[:, -2:-1]))
    w_at_u = QUARTER * (wx[:-1, :-1] + wx[:-1, 1:] + wx[1:, :-1] + wx[1:, 1:])
    az = _derivative(upz, w_at_u, g.dz, 1, scheme)
    # w at interior z-faces.
    zz = np.zeros((g.nx, 1))
    wpz = _pad(W, 1, (-W[:, :1], zz), (zz, -W[:, -1:]))
    bz = _derivative(wpz, W, g.dz, 1, scheme)
    if g.periodic_x:
        wpx = _pad(W, 0, (W[-2:-1], W[-1:]), (W[:1], W[1:2]))
    else:
        sw, se = sign[Side.WEST], sign[Side.EAST]
        wpx = _pad(W, 0, (sw * W[1:2, :], sw * W[:1, :]), (se * W[-1:, :], se * W[-2:-1, :]))
    u_at_w = QUARTER * (u[:-1, :-1] + u[1:, :-1] + u[:-1, 1:] + u[1:, 1:])
    bx = _derivative(wpx, u_at_w, g.dx, 0, scheme)
    return np.concatenate([(ax + az).ravel(), (bx + bz).ravel()])


def yield_viscosity(Z, p, S, eps: float) -> np.ndarray:
    """Regularised yield viscosity ``eta = Z p / (2 sqrt(|S|^2 + eps^2))`` [Pa s] (NUMERICS.md §4).

    The deviatoric stress ``2 eta S`` tends to the yield stress ``Z p S/|S|`` of eq. def:tau for
    ``|S| >> eps``; below, the material creeps at strain rates ~ eps. Negative ``Z`` (possible for
    the dilatancy-angle closures far below equilibrium, MODEL.md §6.4) and negative ``p`` are
    clipped at 0, so that ``V`` stays positive semidefinite.

    Parameters
    ----------
    Z : array_like
        Yield function Z(phi, I) [-].
    p : array_like
        Granular pressure [Pa].
    S : array_like
        Strain-rate norm |S| [s^-1].
    eps : float
        Regularisation strain rate [s^-1] (> 0).
    """
    Z, p, S = (np.asarray(x, dtype=float) for x in (Z, p, S))
    return np.maximum(Z, 0.0) * np.maximum(p, 0.0) / (2.0 * np.sqrt(S * S + eps * eps))


def base_pressure(p_bottom, phi_bottom, rho_s: float, g_normal: float, dz: float, dpf_dz=0.0) -> np.ndarray:
    """Granular pressure at the base under the bottom row of cells [Pa].

    The cells' centre pressure plus the half cell of effective weight between the centre and the
    wall, from the normal component of the momentum balance at rest (paper eq. syst3b:
    ``dp/dz = -phi rho_s g_n - dp_f/dz``):

        p_w = max(p_1, 0) + max(phi_1 rho_s g_n + dp_f/dz, 0) dz / 2

    With the indicator surface ``p_1`` of a thin cell is its mid-material pressure ``rho_s phi g_n
    dz/2`` (:meth:`granflow.model.Model.lithostatic_pressure`), so ``p_w = rho_s phi g_n dz``, the
    whole weight of the film.

    Parameters
    ----------
    p_bottom, phi_bottom : array_like, (nx,)
        Pressure [Pa] and solid fraction [-] of the bottom cells.
    rho_s : float
        Grain density [kg m^-3].
    g_normal : float
        Gravity component towards the base [m s^-2] (``g cos(slope)``).
    dz : float
        Cell height [m].
    dpf_dz : array_like, (nx,) or float
        Pore-pressure gradient over the bottom cells [Pa m^-1] (negative where gas supports the
        grains); 0 when dry.
    """
    p, phi = (np.asarray(x, dtype=float) for x in (p_bottom, phi_bottom))
    weight = np.maximum(phi * rho_s * g_normal + np.asarray(dpf_dz, dtype=float), 0.0)
    return np.maximum(p, 0.0) + HALF * dz * weight


class GasBorder(NamedTuple):
    """The pore-pressure border of the saddle-point matrix (:meth:`SaddleAssembler.saddle`)."""

    wet: np.ndarray
    """bool (n_cells,): cells carrying a p_f unknown (the others have p_f = 0)."""
    block: sp.spmatrix
    """(n_wet, n_wet): the gas rows' own block, already scaled (``-M_wet/p_atm``)."""


class VelocityRegion(NamedTuple):
    """The velocity unknowns kept in the saddle-point system of one step
    (:meth:`SaddleAssembler.region`); the others are ``u = 0`` and are not unknowns."""

    mask: np.ndarray
    """bool (n_unknowns,): kept velocity unknowns."""
    renum: np.ndarray
    """int (n_unknowns,): new index of each kept unknown, -1 for the others."""
    a_keep: np.ndarray
    """int: entries of the velocity block's fixed pattern whose row and column are kept."""
    rows: np.ndarray
    cols: np.ndarray
    """Renumbered rows and columns of those entries."""
    size: int
    """Number of kept velocity unknowns."""
    pc: sp.csr_matrix
    pn: sp.csr_matrix
    diag: np.ndarray
    """The maps of :meth:`SaddleAssembler.velocity_data` restricted to the kept entries."""


@dataclass(frozen=True, eq=False)
class _SaddleLayout:
    """Sparsity pattern of one saddle-point matrix (:meth:`SaddleAssembler.saddle`) and the map
    from the concatenated block values to its CSR data."""

    unknowns: np.ndarray
    """Pressure unknowns (cells) it was built for."""
    velocity: VelocityRegion | None
    border: GasBorder | None
    """Compared by identity (the layout holds them, so their ids cannot be reused)."""
    n: int
    """Number of velocity unknowns."""
    gp: np.ndarray
    gv: np.ndarray
    idx: np.ndarray
    """Pressure columns and values of the Grad entries, and the cells of the pressure unknowns."""
    fv: np.ndarray | None
    blk: sp.coo_matrix | None
    """Grad values of the gas border and its block."""
    size: int
    order: np.ndarray
    indptr: np.ndarray
    indices: np.ndarray
    """CSR pattern and the permutation of the concatenated values into its data."""

    @classmethod
    def build(cls, asm: SaddleAssembler, unknowns: np.ndarray, velocity: VelocityRegion | None,
              border: GasBorder | None) -> _SaddleLayout:
        n = asm.n if velocity is None else velocity.size
        rows_a, cols_a = (asm._rows, asm._cols) if velocity is None else (velocity.rows, velocity.cols)
        gr, gp, gv, idx = asm._grad_columns(unknowns, n, velocity)
        m = idx.size
        diag = n + np.arange(m)
        rows = [rows_a, gr, gp, diag]
        cols = [cols_a, gp, gr, diag]
        size = n + m
        fv, blk = None, None
        if border is not None:
            fr, fp, fv, widx = asm._grad_columns(np.asarray(border.wet, dtype=bool), size, velocity)
            blk = sp.coo_matrix(border.block)
            if blk.shape != (widx.size, widx.size):
                raise GranflowInputError(f"border block shape {blk.shape} != ({widx.size}, {widx.size})")
            rows += [fr, fp, size + blk.row.astype(np.int64)]
            cols += [fp, fr, size + blk.col.astype(np.int64)]
            size += widx.size
        rows, cols = np.concatenate(rows), np.concatenate(cols)
        order = np.argsort(rows * size + cols, kind="stable")  # = lexsort((cols, rows)), 2x cheaper
        rows, cols = rows[order], cols[order]
        if np.any((np.diff(rows) == 0) & (np.diff(cols) == 0)):
            raise GranflowInputError("saddle: duplicate entries in the saddle-point pattern")
        indptr = np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=size))])
        return cls(unknowns=unknowns.copy(), velocity=velocity, border=border, n=n, gp=gp, gv=gv,
                   idx=idx, fv=fv, blk=blk, size=size, order=order, indptr=indptr, indices=cols)


class SaddleAssembler:
    """Fast assembly of the (u, p) saddle-point matrix with a fixed sparsity pattern.

    The velocity block ``A = diag(rho_f/dt) + ec^T diag(eta_c) ec + en^T diag(w_n eta_n) en`` is
    linear in ``(rho_f/dt, eta_c, eta_n)``: its CSR data are ``P_c eta_c + P_n (w_n eta_n)`` plus the
    diagonal, with the sparse maps ``P_c``, ``P_n`` built once from the operators. The pressure
    unknowns are the *active* cells only (inactive cells have ``p = 0`` and are not unknowns), so

        K = [[A, Grad_act], [Grad_act^T, -diag(C_act)]],   Grad_act = Grad[:, active].

    Parameters
    ----------
    ops : Operators
        Or an :class:`granflow.axisymmetric.AssemblyOperators`, whose ``cell_rows`` (several cell
        rows, each weighted by ``eta_c``) take the place of ``ec``.
    """

    def __init__(self, ops: Operators) -> None:
        g = ops.grid
        n = g.n_unknowns
        self.ops = ops
        self.n = n
        cell_rows = getattr(ops, "cell_rows", None)
        if cell_rows is None:
            kc, rc, vc = product_pairs(ops.ec, n)
        else:
            kc, rc, vc = (np.concatenate(a) for a in zip(*(product_pairs(r, n) for r in cell_rows)))
        kn, rn, vn = product_pairs(ops.en, n)
        kd = np.arange(n, dtype=np.int64) * (n + 1)
        keys = sorted_unique(np.concatenate([kc, kn, kd]))
        self._rows = (keys // n).astype(np.int64)
        self._cols = (keys % n).astype(np.int64)
        nnz = keys.size
        self._pc = sp.csr_matrix((vc, (np.searchsorted(keys, kc), rc)), shape=(nnz, g.n_cells))
        self._pn = sp.csr_matrix((vn, (np.searchsorted(keys, kn), rn)), shape=(nnz, g.n_nodes))
        self._diag = np.searchsorted(keys, kd)
        self._row_ptr = np.searchsorted(self._rows, np.arange(n + 1))  # keys are sorted by row
        self._wn = np.asarray(ops.node_weights)
        self._layout: _SaddleLayout | None = None
        """Pattern of the last :meth:`saddle` (rebuilt when its unknowns, region or border change)."""
        gc = ops.grad.tocoo()
        self._g_rows = gc.row.astype(np.int64)
        self._g_cols = gc.col.astype(np.int64)
        self._g_vals = gc.data

    def velocity_data(self, rho_over_dt, eta_c, eta_n, region: VelocityRegion | None = None) -> np.ndarray:
        """CSR data of ``A`` in the fixed pattern (see :meth:`velocity_matrix`); with ``region``
        only its kept entries (``region.a_keep``; ``rho_over_dt`` is still given on every
        velocity unknown)."""
        pc, pn, diag = (self._pc, self._pn, self._diag) if region is None else (region.pc, region.pn, region.diag)
        data = pc @ np.asarray(eta_c, dtype=float) + pn @ (self._wn * np.asarray(eta_n))
        rho_over_dt = np.asarray(rho_over_dt, dtype=float)
        data[diag] += rho_over_dt if region is None or rho_over_dt.ndim == 0 else rho_over_dt[region.mask]
        return data

    def velocity_matrix(self, data) -> sp.csr_matrix:
        """``A`` as a CSR matrix from :meth:`velocity_data`."""
        return sp.csr_matrix((data, (self._rows, self._cols)), shape=(self.n, self.n))

    def region(self, mask) -> VelocityRegion:
        """The restriction of the saddle-point system to the velocity unknowns of ``mask``
        (bool, (n_unknowns,)); pass it as ``saddle(..., velocity=region)``."""
        mask = np.array(mask, dtype=bool)  # a copy: the layout cache keys on the region
        if mask.shape != (self.n,):
            raise GranflowInputError(f"region: mask must have shape ({self.n},), got {mask.shape}")
        size = int(np.count_nonzero(mask))
        renum = np.full(self.n, -1, dtype=np.int64)
        renum[mask] = np.arange(size)
        kept_rows = np.flatnonzero(mask)  # entries of the kept rows (contiguous per row), then kept columns
        starts = self._row_ptr[kept_rows]
        counts = self._row_ptr[kept_rows + 1] - starts
        offsets = np.repeat(starts - (np.cumsum(counts) - counts), counts)
        candidates = offsets + np.arange(int(counts.sum()))
        a_keep = candidates[mask[self._cols[candidates]]]
        return VelocityRegion(mask=mask, renum=renum, a_keep=a_keep, rows=renum[self._rows[a_keep]],
                              cols=renum[self._cols[a_keep]], size=size, pc=self._pc[a_keep],
                              pn=self._pn[a_keep], diag=np.searchsorted(a_keep, self._diag[mask]))

    def _grad_columns(self, mask, offset: int, velocity: VelocityRegion | None = None):
        """Triplets of ``Grad[:, mask]`` with the columns renumbered from ``offset`` (and the
        rows restricted to, and renumbered in, ``velocity``)."""
        idx = np.flatnonzero(mask)
        renum = np.full(mask.size, -1, dtype=np.int64)
        renum[idx] = offset + np.arange(idx.size)
        keep = mask[self._g_cols]
        rows = self._g_rows
        if velocity is not None:
            keep &= velocity.mask[rows]
            rows = velocity.renum[rows]
        return rows[keep], renum[self._g_cols[keep]], self._g_vals[keep], idx

    def saddle(self, a_data, active, C, border: GasBorder | None = None,
               unknowns=None, velocity: VelocityRegion | None = None) -> sp.csr_matrix:
        """``[[A, Grad_act], [Grad_act^T, -diag(C_act)]]``, pressure unknowns = active cells,
        optionally bordered by the pore-pressure block (module docstring).

        Parameters
        ----------
        a_data : ndarray
            From :meth:`velocity_data`.
        active : ndarray of bool, (n_cells,)
        C : ndarray, (n_cells,)
            Constraint coefficient (only the active entries are used).
        border : GasBorder, optional
            p_f unknowns on ``border.wet`` (ordered after the pressures), coupled to the velocity
            by ``Grad_wet`` and its transpose.
        unknowns : ndarray of bool, (n_cells,), optional
            Pressure unknowns, a superset of ``active`` (default: ``active``). The extra cells get
            the row ``-p = rhs`` (their right-hand side must be 0, so p = 0) and keep their
            ``Grad`` entries as stored zeros, so the sparsity pattern depends on ``unknowns``
            only: a solver that keeps its symbolic analysis while the pattern is unchanged
            (:mod:`granflow.solvers.pardiso`) then re-uses it when the active set changes.
        velocity : VelocityRegion, optional
            Keep only these velocity unknowns (:meth:`region`; the others are ``u = 0``): the
            velocity block is ``A[kept][:, kept]`` and the first ``velocity.size`` unknowns are
            the kept velocities in their original order. Default: all of them.

        Returns a CSR matrix (sorted indices, no duplicates). Its pattern depends on
        ``unknowns``, ``velocity`` and ``border`` only and is kept between calls: the Picard
        sweeps of a step (same objects, same unknowns) only gather their values into it.
        """
        active = np.asarray(active, dtype=bool)
        unknowns = active if unknowns is None else np.asarray(unknowns, dtype=bool)
        if np.any(active & ~unknowns):
            raise GranflowInputError("saddle: every active cell must be a pressure unknown")
        a_data = np.asarray(a_data)
        if velocity is not None and a_data.size != velocity.a_keep.size:  # data of the whole pattern
            a_data = a_data[velocity.a_keep]
        lay = self._layout
        if not (lay is not None and lay.velocity is velocity and lay.border is border
                and np.array_equal(lay.unknowns, unknowns)):
            lay = self._layout = _SaddleLayout.build(self, unknowns, velocity, border)
        on = active[lay.idx]
        gv = lay.gv if on.all() else np.where(on[lay.gp - lay.n], lay.gv, 0.0)
        vals = [a_data, gv, gv, np.where(on, -np.asarray(C, dtype=float)[lay.idx], -1.0)]
        if border is not None:
            vals += [lay.fv, lay.fv, lay.blk.data]
        data = np.concatenate(vals)[lay.order]
        return sp.csr_matrix((data, lay.indices, lay.indptr), shape=(lay.size, lay.size))

    def bordered(self, K: sp.spmatrix, col_u: sp.spmatrix, row_u: sp.spmatrix,
                 diag: sp.spmatrix) -> sp.csc_matrix:
        """Append ``k`` unknowns coupled to the velocity only: ``[[K, [col_u; 0]], [[row_u, 0], diag]]``.

        A generic (slower, ``scipy.sparse.bmat``) form of the border; the model's pore-pressure
        coupling uses the fixed-pattern, symmetric ``saddle(..., border=GasBorder(...))``, i.e.
        ``col_u = Grad_wet``, ``row_u = Grad_wet^T = -Div_wet`` and ``diag = -M/p_atm``.

        Parameters
        ----------
        K : sparse, (n + m, n + m)
            Output of :meth:`saddle` (m active pressure unknowns).
        col_u : sparse, (n, k)
        row_u : sparse, (k, n)
        diag : sparse, (k, k)
        """
        m = K.shape[0] - self.n
        k = diag.shape[0]
        col = sp.vstack([sp.csr_matrix(col_u), sp.csr_matrix((m, k))])
        row = sp.hstack([sp.csr_matrix(row_u), sp.csr_matrix((k, m))])
        return sp.bmat([[K, col], [row, diag]], format="csc")

