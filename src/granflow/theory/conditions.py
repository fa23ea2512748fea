"""Numerical checker of the conditions a closure (Z, f) must satisfy (MODEL.md §4).

Conditions (keys of :class:`Condition`, statements in :data:`DESCRIPTIONS`): C1, C2 (the paper's
relaxed Z + I dZ/dI >= 0), C2_strict (Barker's dZ/dI > 0), C3, dissipation (Z >= f), equilibrium
(Theorem th2) and Z_nonnegative (MODEL.md §6.4). Z, f, I are dimensionless, p in Pa.

:func:`check` evaluates them on a grid of r = I/I_eq(phi) (log-spaced), phi (default: I_eq from 1e-3
to 1) and p (default 1 Pa to 1e5 Pa), plus a "jammed" row phi = phi_max (I_eq = 0) on an absolute I
grid. Failing grid points are merged into intervals whose end points are refined by bisection in
ln I (equivalently ln r) to :data:`BOUNDARY_LOG_TOL`. Points where the closure is not finite are
skipped and reported. :func:`condition_map` gives the pointwise verdicts on a (phi, I) mesh.

Margins (the "worst value" of an inequality is the minimum margin; >= 0 or > 0 means it holds):
C2: Z + I Z_I; C2_strict: Z_I; C3: I f_I - 2p f_p (that is -2p times the C3 expression);
dissipation: Z - f; Z_nonnegative: Z; equilibrium: sign(I - I_eq) f. C1 reports the relative
residual |Z - I Z_I/2 - f - I f_I| / (|Z| + |I Z_I|/2 + |f| + |I f_I|).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from granflow.errors import GranflowInputError
from granflow.rheology.base import Closure
from granflow.theory.report import (  # noqa: F401  (re-exported)
    DESCRIPTIONS,
    WORST_KEY,
    CheckReport,
    Condition,
    ConditionResult,
    _clean,
    _num,
)

_CONDS = tuple(Condition)
#: Default range of r = I/I_eq(phi) and number of points (40 per decade).
DEFAULT_I_RATIO_RANGE = (1e-3, 1e3)
DEFAULT_N_RATIO = 241
#: Default phi grid: phi_eq(I_eq) for I_eq log-spaced on this range (near phi_max up to I_eq = 1).
DEFAULT_I_EQ_RANGE = (1e-3, 1.0)
DEFAULT_N_PHI = 7
#: Default pressure grid [Pa].
DEFAULT_P_RANGE = (1.0, 1e5)
DEFAULT_N_P = 6
#: Absolute I grid of the jammed row phi = phi_max (I_eq = 0).
DEFAULT_JAMMED_I_RANGE = (1e-6, 1e2)
DEFAULT_N_JAMMED = 161
#: Relative tolerance of C1 (relative residual).
C1_TOLERANCE = 1e-9
#: Relative tolerance of f(I_eq) = 0, relative to |Z| + |I df/dI| at I_eq.
EQUILIBRIUM_TOLERANCE = 1e-9
#: Relative slack of the non-strict inequalities C2 and dissipation (relative to their terms).
INEQUALITY_TOLERANCE = 1e-12
#: |I/I_eq - 1| below which a point counts as "at equilibrium" (checked by f = 0, not by sign).
AT_EQUILIBRIUM_RTOL = 1e-12
#: Bisection stops when the bracket in ln I is below this (boundaries accurate to ~5e-11 relative).
BOUNDARY_LOG_TOL = 1e-10
#: Two refined end points closer than this (relative) are the same boundary (merging over p).
SAME_BOUNDARY_RTOL = 1e-9


@dataclass(frozen=True)
class Tolerances:
    """Tolerances of the checks (see the module constants)."""

    c1: float = C1_TOLERANCE
    equilibrium: float = EQUILIBRIUM_TOLERANCE
    inequality: float = INEQUALITY_TOLERANCE

    def to_dict(self) -> dict[str, float]:
        return {"C1_relative": self.c1, "equilibrium_relative": self.equilibrium,
                "inequality_relative": self.inequality, "boundary_log": BOUNDARY_LOG_TOL}


@dataclass(frozen=True)
class _Pointwise:
    holds: dict[Condition, np.ndarray]
    finite: dict[Condition, np.ndarray]
    value: dict[Condition, np.ndarray]
    extra: dict[str, np.ndarray]

    def fails(self, cond: Condition) -> np.ndarray:
        return self.finite[cond] & ~self.holds[cond]


def _evaluate(closure: Closure, phi, p, I, tol: Tolerances) -> _Pointwise:
    """Evaluate every condition at the points (phi, p, I) (broadcast together)."""
    with np.errstate(all="ignore"):
        phi, p, I = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (phi, p, I)))
        Z = np.broadcast_to(closure.Z(phi, I), I.shape)
        Zi = np.broadcast_to(closure.dZ_dI(phi, I), I.shape)
        f = np.broadcast_to(closure.f(phi, p, I), I.shape)
        fi = np.broadcast_to(closure.df_dI(phi, p, I), I.shape)
        fp = np.broadcast_to(closure.df_dp(phi, p, I), I.shape)
        Ieq = np.broadcast_to(closure.I_eq(phi), I.shape)
        fin = {k: np.isfinite(v) for k, v in (("Z", Z), ("Zi", Zi), ("f", f), ("fi", fi), ("fp", fp))}
        okI = np.isfinite(I) & np.isfinite(p)

        res = Z - 0.5 * I * Zi - (f + I * fi)
        scale = np.abs(Z) + 0.5 * np.abs(I * Zi) + np.abs(f) + np.abs(I * fi)
        rel = np.where(scale > 0, np.abs(res) / np.where(scale > 0, scale, 1.0), 0.0)
        c2 = Z + I * Zi
        c3 = I * fi - 2.0 * p * fp
        diss = Z - f
        above = I > Ieq * (1.0 + AT_EQUILIBRIUM_RTOL)
        below = I < Ieq * (1.0 - AT_EQUILIBRIUM_RTOL)
        at_eq = ~above & ~below
        eq_value = np.where(above, f, np.where(below, -f, np.nan))
        eq_at = np.abs(f) <= tol.equilibrium * (np.abs(Z) + np.abs(I * fi))
        ineq = tol.inequality
        holds = {
            Condition.C1: rel <= tol.c1,
            Condition.C2: c2 >= -ineq * (np.abs(Z) + np.abs(I * Zi)),
            Condition.C2_STRICT: Zi > 0,
            Condition.C3: c3 > 0,
            Condition.DISSIPATION: diss >= -ineq * (np.abs(Z) + np.abs(f)),
            Condition.EQUILIBRIUM: np.where(at_eq, eq_at, eq_value > 0),
            Condition.Z_NONNEGATIVE: Z >= 0,
        }
        finite = {
            Condition.C1: fin["Z"] & fin["Zi"] & fin["f"] & fin["fi"],
            Condition.C2: fin["Z"] & fin["Zi"],
            Condition.C2_STRICT: fin["Zi"],
            Condition.C3: fin["fi"] & fin["fp"],
            Condition.DISSIPATION: fin["Z"] & fin["f"],
            Condition.EQUILIBRIUM: fin["f"] & np.isfinite(Ieq) & (~at_eq | fin["Z"] & fin["fi"]),
            Condition.Z_NONNEGATIVE: fin["Z"],
        }
        finite = {k: v & okI for k, v in finite.items()}
        value = {
            Condition.C1: rel, Condition.C2: c2, Condition.C2_STRICT: Zi + 0.0, Condition.C3: c3,
            Condition.DISSIPATION: diss, Condition.EQUILIBRIUM: eq_value, Condition.Z_NONNEGATIVE: Z + 0.0,
        }
        all_finite = okI & fin["Z"] & fin["Zi"] & fin["f"] & fin["fi"] & fin["fp"]
    return _Pointwise(holds, finite, value, {"abs_residual": np.abs(res), "f": f + 0.0, "all_finite": all_finite})


def condition_map(closure: Closure, phi, I, p: float, *, tolerances: Tolerances | None = None,
                  with_finite: bool = False) -> dict[str, np.ndarray]:
    """Pointwise verdict of every condition on a (phi, I) mesh at fixed pressure.

    Parameters
    ----------
    closure : Closure
        The closure to examine.
    phi, I : array_like
        Packing fractions [-] and inertial numbers [-]. Two 1-D arrays give the mesh
        ``(phi.size, I.size)`` (``indexing="ij"``); otherwise they are broadcast together.
    p : float
        Granular pressure [Pa].
    tolerances : Tolerances, optional
        Defaults as in :func:`check`.
    with_finite : bool
        Also return the key ``"finite"`` (closure finite at the point).

    Returns
    -------
    dict of str to ndarray of bool
        ``{condition key: holds}``; False where the closure is not finite. The equilibrium verdict
        is pointwise: sign(f) = sign(I - I_eq), or f = 0 at I = I_eq.

    Examples
    --------
    >>> from granflow.rheology import make_closure
    >>> m = condition_map(make_closure("drucker_prager"), [0.5, 0.55], [0.1, 1.0, 10.0], 1e3)
    >>> bool(m["C2"].all()), bool(m["C2_strict"].any()), m["C1"].shape
    (True, False, (2, 3))
    """
    phi, I = np.asarray(phi, dtype=float), np.asarray(I, dtype=float)
    if phi.ndim == 1 and I.ndim == 1:
        phi, I = np.meshgrid(phi, I, indexing="ij")
    pw = _evaluate(closure, phi, p, I, tolerances or Tolerances())
    out = {c.value: np.asarray(pw.holds[c] & pw.finite[c], dtype=bool) for c in _CONDS}
    if with_finite:
        out["finite"] = np.asarray(pw.extra["all_finite"], dtype=bool)
    return out


# Grid blocks, runs of failing points, bisection --------------------------------------------------
@dataclass
class _Block:
    """Rows (phi, p) each with its own I grid; ``ratio`` True when I = r I_eq with a shared r."""

    phi: np.ndarray  # (rows,)
    p: np.ndarray  # (rows,)
    I_eq: np.ndarray  # (rows,)
    I: np.ndarray  # (rows, n)
    ratio: bool
    pw: _Pointwise | None = None


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Inclusive index runs (start, stop) of True in a 1-D boolean array."""
    m = np.concatenate(([False], np.asarray(mask, dtype=bool), [False]))
    d = np.flatnonzero(np.diff(m.astype(np.int8)))
    return [(int(a), int(b) - 1) for a, b in zip(d[::2], d[1::2])]


@dataclass
class _RowRun:
    block: _Block
    row: int
    start: int
    stop: int
    cond: Condition | None  # None: a run of non-finite points (not refined)
    lo: float = math.nan  # refined I end points, and whether they are the edges of the grid
    hi: float = math.nan
    open_below: bool = False
    open_above: bool = False


def _bisect(closure: Closure, runs: list[_RowRun], tol: Tolerances) -> None:
    """Refine the end points of all failing runs at once (vectorised bisection in ln I)."""
    brackets = []  # (run, side, log_pass, log_fail)
    for rr in runs:
        I_row, n = rr.block.I[rr.row], rr.block.I.shape[1]
        rr.lo, rr.hi = float(I_row[rr.start]), float(I_row[rr.stop])
        rr.open_below, rr.open_above = rr.start == 0, rr.stop == n - 1
        if rr.cond is None:
            continue
        if rr.start > 0:
            brackets.append((rr, "lo", math.log(I_row[rr.start - 1]), math.log(I_row[rr.start])))
        if rr.stop < n - 1:
            brackets.append((rr, "hi", math.log(I_row[rr.stop + 1]), math.log(I_row[rr.stop])))
    if not brackets:
        return
    a, b = (np.array([br[k] for br in brackets]) for k in (2, 3))
    phi, p = (np.array([getattr(br[0].block, x)[br[0].row] for br in brackets]) for x in ("phi", "p"))
    cidx = np.array([_CONDS.index(br[0].cond) for br in brackets])
    width = float(np.max(np.abs(b - a)))
    for _ in range(max(1, math.ceil(math.log2(width / BOUNDARY_LOG_TOL))) if width > 0 else 0):
        mid = 0.5 * (a + b)
        pw = _evaluate(closure, phi, p, np.exp(mid), tol)
        fails = np.stack([pw.fails(c) for c in _CONDS])[cidx, np.arange(cidx.size)]
        b, a = np.where(fails, mid, b), np.where(fails, a, mid)
    edge = np.exp(0.5 * (a + b))
    for (rr, side, *_), x in zip(brackets, edge):
        setattr(rr, side, float(x))


def _point(block: _Block, row: int, k: int, value=None) -> dict:
    I, Ieq = float(block.I[row, k]), float(block.I_eq[row])
    return {"phi": float(block.phi[row]), "p": float(block.p[row]), "I_eq": Ieq, "I": I,
            "r": I / Ieq if block.ratio and Ieq > 0 else None, "value": _num(value)}


def _worst_index(values: np.ndarray, mask: np.ndarray, cond: Condition | None):
    """(row, k) of the worst value among mask (max for C1, min otherwise), or None."""
    v = np.where(mask & np.isfinite(values), values, np.nan)
    if np.all(np.isnan(v)):
        return None
    flat = np.nanargmax(v) if cond is Condition.C1 else np.nanargmin(v)
    return np.unravel_index(flat, v.shape)


def _region(runs: list[_RowRun], cond: Condition | None, kind: str, covers: bool) -> dict:
    """Assemble one failing region (a run of r indices over the union of rows) as a dict."""
    blk = runs[0].block
    groups: list[dict] = []  # boundaries merged over p when identical
    for rr in runs:
        phi, p = float(blk.phi[rr.row]), float(blk.p[rr.row])
        for g in groups:
            if (g["phi"] == phi and g["open_below"] == rr.open_below and g["open_above"] == rr.open_above
                    and math.isclose(g["I_interval"][0], rr.lo, rel_tol=SAME_BOUNDARY_RTOL)
                    and math.isclose(g["I_interval"][1], rr.hi, rel_tol=SAME_BOUNDARY_RTOL)):
                g["p_range"] = [min(g["p_range"][0], p), max(g["p_range"][1], p)]
                break
        else:
            Ieq = float(blk.I_eq[rr.row])
            groups.append({
                "phi": phi, "I_eq": Ieq, "p_range": [p, p],
                "r_interval": [rr.lo / Ieq, rr.hi / Ieq] if blk.ratio and Ieq > 0 else None,
                "I_interval": [rr.lo, rr.hi], "open_below": rr.open_below, "open_above": rr.open_above,
            })
    worst = None
    if cond is not None and blk.pw is not None:
        vals = blk.pw.value[cond]
        mask = np.zeros(vals.shape, dtype=bool)
        for rr in runs:
            mask[rr.row, rr.start:rr.stop + 1] = True
        idx = _worst_index(vals, mask, cond)
        if idx is not None:
            worst = _point(blk, idx[0], idx[1], value=vals[idx])
    r_int = None
    if blk.ratio and all(g["r_interval"] is not None for g in groups):
        r_int = [min(g["r_interval"][0] for g in groups), max(g["r_interval"][1] for g in groups)]
    return {
        "kind": kind,
        "r_interval": r_int,
        "I_interval": [min(g["I_interval"][0] for g in groups), max(g["I_interval"][1] for g in groups)],
        "phi_range": [min(g["phi"] for g in groups), max(g["phi"] for g in groups)],
        "p_range": [min(g["p_range"][0] for g in groups), max(g["p_range"][1] for g in groups)],
        "open_below": any(g["open_below"] for g in groups),
        "open_above": any(g["open_above"] for g in groups),
        "covers_grid": covers,
        "n_points": int(sum(rr.stop - rr.start + 1 for rr in runs)),
        "worst": worst,
        "boundaries": groups,
    }


def _block_runs(block: _Block, mask: np.ndarray, cond: Condition | None) -> list[list[_RowRun]]:
    """Runs of True in ``mask`` (rows, n), grouped by the runs of its union over rows."""
    out = []
    for k0, k1 in _runs(mask.any(axis=0)):
        grp = [_RowRun(block, row, k0 + a, k0 + b, cond)
               for row in range(mask.shape[0]) for a, b in _runs(mask[row, k0:k1 + 1])]
        out.append(grp)
    return out


# check() -----------------------------------------------------------------------------------------
def _log_grid(rng, n: int, what: str) -> np.ndarray:
    lo, hi = (float(v) for v in rng)
    if not (0 < lo < hi and math.isfinite(hi)) or n < 2:
        raise GranflowInputError(f"{what}: need 0 < low < high and at least 2 points (got {rng}, {n})")
    return np.logspace(math.log10(lo), math.log10(hi), int(n))


def _build_blocks(closure, r, phis, ps, jammed_I) -> list[_Block]:
    """Ratio block (I = r I_eq, rows with I_eq > 0) and jammed block (absolute I, I_eq = 0)."""
    Ieq = np.asarray(closure.I_eq(phis), dtype=float)
    blocks = []
    for sel, ratio in ((Ieq > 0, True), (~(Ieq > 0), False)):
        if not sel.any() or (not ratio and jammed_I is None):
            continue
        ph, pp = (x.ravel() for x in np.meshgrid(phis[sel], ps, indexing="ij"))
        ie = np.repeat(Ieq[sel], ps.size)
        I = ie[:, None] * r[None, :] if ratio else np.broadcast_to(jammed_I, (ie.size, jammed_I.size))
        blocks.append(_Block(ph, pp, ie, I, ratio=ratio))
    return blocks


def _note(cond: Condition, vals: list[np.ndarray], passed: bool) -> str | None:
    finite_vals = np.concatenate([v[np.isfinite(v)] for v in vals]) if vals else np.array([])
    if passed or finite_vals.size == 0 or cond is Condition.C1 or np.any(finite_vals != 0):
        return None
    if cond is Condition.EQUILIBRIUM:
        return ("f = 0 identically on the grid (isochoric): f(I_eq) = 0 holds but f > 0 for I > I_eq "
                "and f < 0 for I < I_eq fail everywhere")
    what = {Condition.C3: "I df/dI - 2p df/dp", Condition.C2_STRICT: "dZ/dI"}.get(cond, "the margin")
    return f"{what} = 0 identically on the grid, so the strict inequality fails everywhere"


def _sample_grid(closure, I_ratio_range, n_ratio: int, phi_values, p_values, jammed_I_range,
                 n_jammed: int):
    """The sample points of :func:`check`: ``(r, phis, ps, jammed_I)`` -- the ratios I/I_eq with
    r = 1 on the grid, the packings (phi_max appended for the jammed row), the pressures [Pa] and
    the jammed row's absolute I (None when ``jammed_I_range`` is None)."""
    phi_max = closure.material.phi_max
    r = _log_grid(I_ratio_range, n_ratio, "I_ratio_range")
    if r[0] <= 1.0 <= r[-1]:  # put r = 1 (f(I_eq) = 0 is checked there) exactly on the grid
        r = np.union1d(r[np.abs(np.log(r)) > 1e3 * AT_EQUILIBRIUM_RTOL], [1.0])
    if phi_values is None:
        phis = np.asarray(closure.equilibrium.phi_eq(_log_grid(DEFAULT_I_EQ_RANGE, DEFAULT_N_PHI, "I_eq")))
    else:
        phis = np.atleast_1d(np.asarray(phi_values, dtype=float))
    if np.any(~np.isfinite(phis)) or np.any(phis <= 0) or np.any(phis > phi_max):
        raise GranflowInputError(f"phi_values must lie in (0, phi_max = {phi_max}], got {phis.tolist()}")
    ps = (_log_grid(DEFAULT_P_RANGE, DEFAULT_N_P, "p") if p_values is None
          else np.atleast_1d(np.asarray(p_values, dtype=float)))
    if np.any(~np.isfinite(ps)) or np.any(ps <= 0):
        raise GranflowInputError(f"p_values must be positive pressures [Pa], got {ps.tolist()}")
    jammed = jammed_I_range is not None
    jammed_I = _log_grid(jammed_I_range, n_jammed, "jammed_I_range") if jammed else None
    if jammed and not np.any(phis == phi_max):
        phis = np.append(phis, phi_max)
    return r, phis, ps, jammed_I


def _failing_runs(closure, blocks: list[_Block], tol) -> dict:
    """Condition (None: not finite) -> ``[(block, runs of failing points)]``, the runs' ends
    refined by bisection."""
    grouped: dict[Condition | None, list[tuple[_Block, list[_RowRun]]]] = {c: [] for c in (*_CONDS, None)}
    all_runs: list[_RowRun] = []
    for b in blocks:
        for c in (*_CONDS, None):
            mask = b.pw.fails(c) if c is not None else ~b.pw.extra["all_finite"]
            for grp in _block_runs(b, mask, c):
                grouped[c].append((b, grp))
                all_runs.extend(grp)
    _bisect(closure, all_runs, tol)
    return grouped


def _condition_result(c: Condition, blocks: list[_Block], grouped) -> ConditionResult:
    """One condition's result: its worst point, the regions where it fails, counts, extras."""
    fails_where, vals, n_pts, n_nf = [], [], 0, 0
    worst_val, worst_pt = None, None
    for b in blocks:
        v, fin = b.pw.value[c], b.pw.finite[c]
        n_pts += v.size
        n_nf += int((~fin).sum())
        vals.append(np.where(fin, v, np.nan))
        idx = _worst_index(v, fin, c)
        if idx is not None:
            cand = float(v[idx])
            better = worst_val is None or (cand > worst_val if c is Condition.C1 else cand < worst_val)
            if better:
                worst_val, worst_pt = cand, _point(b, idx[0], idx[1], value=cand)
    covers = all(np.array_equal(b.pw.fails(c), b.pw.finite[c]) for b in blocks)
    for b, grp in grouped:
        fails_where.append(_region(grp, c, "grid" if b.ratio else "jammed", covers))
    extra: dict[str, Any] = {}
    if c is Condition.C1:
        extra["max_abs_residual"] = max(
            (float(np.nanmax(np.where(b.pw.finite[c], b.pw.extra["abs_residual"], np.nan)))
             for b in blocks if b.pw.finite[c].any()), default=None)
    if c is Condition.EQUILIBRIUM:
        at_eq = [np.abs(b.pw.extra["f"][(b.I == b.I_eq[:, None]) & b.pw.finite[c]]) for b in blocks if b.ratio]
        extra["max_abs_f_at_eq"] = max((float(x.max()) for x in at_eq if x.size), default=None)
    passed = not fails_where
    return ConditionResult(
        condition=c, passed=passed, worst_value=_num(worst_val), worst_point=worst_pt,
        fails_where=fails_where, n_points=n_pts, n_not_finite=n_nf, extra=extra, note=_note(c, vals, passed),
    )


def check(
    closure: Closure,
    *,
    I_ratio_range: tuple[float, float] = DEFAULT_I_RATIO_RANGE,
    n_ratio: int = DEFAULT_N_RATIO,
    phi_values=None,
    p_values=None,
    jammed: bool = True,
    jammed_I_range: tuple[float, float] = DEFAULT_JAMMED_I_RANGE,
    n_jammed: int = DEFAULT_N_JAMMED,
    tolerances: Tolerances | None = None,
) -> CheckReport:
    """Check a closure against C1, C2, C2_strict, C3, dissipation, equilibrium and Z >= 0.

    Parameters
    ----------
    closure : Closure
        Any registered closure (reference closures are checked the same way).
    I_ratio_range : (float, float)
        Range of r = I/I_eq(phi) [-], log-spaced with ``n_ratio`` points (default 241, 40 per
        decade); r = 1, where f(I_eq) = 0 is checked, is put on the grid.
    n_ratio : int
    phi_values : array_like, optional
        Packing fractions in (0, phi_max]. Default: phi_eq(I_eq) for 7 I_eq log-spaced on
        [1e-3, 1]. Those with I_eq = 0 (phi = phi_max) use the absolute I grid of the jammed row.
    p_values : array_like, optional
        Pressures [Pa]; default 6 values log-spaced on [1, 1e5].
    jammed : bool
        Also check phi = phi_max (I_eq = 0) on the absolute grid ``jammed_I_range`` (default True).
    jammed_I_range : (float, float), n_jammed : int
        Absolute I range [-] and number of points of the jammed row.
    tolerances : Tolerances, optional
        C1 relative tolerance (1e-9), f(I_eq) = 0 relative tolerance (1e-9), slack of the
        non-strict inequalities (1e-12, relative).

    Returns
    -------
    CheckReport

    Examples
    --------
    >>> from granflow.rheology import make_closure
    >>> rep = check(make_closure("drucker_prager", delta_deg=30.0))
    >>> rep.failed()  # C3 fails at phi = phi_max only, where f = sin(delta) does not depend on I
    ['C2_strict', 'C3']
    >>> check(make_closure("drucker_prager"), jammed=False).failed()
    ['C2_strict']
    """
    tol = tolerances or Tolerances()
    r, phis, ps, jammed_I = _sample_grid(closure, I_ratio_range, n_ratio, phi_values, p_values,
                                         jammed_I_range if jammed else None, n_jammed)
    blocks = _build_blocks(closure, r, phis, ps, jammed_I)
    for b in blocks:
        b.pw = _evaluate(closure, b.phi[:, None], b.p[:, None], b.I, tol)
    grouped = _failing_runs(closure, blocks, tol)
    results = {c.value: _condition_result(c, blocks, grouped[c]) for c in _CONDS}
    not_finite = [_region(grp, None, "grid" if b.ratio else "jammed", False) for b, grp in grouped[None]]
    grid = {
        "I_ratio_range": [float(r[0]), float(r[-1])], "n_ratio": int(r.size),
        "phi": phis.tolist(), "I_eq": np.asarray(closure.I_eq(phis), dtype=float).tolist(), "p": ps.tolist(),
        "jammed_I_range": None if jammed_I is None else [float(jammed_I[0]), float(jammed_I[-1])],
        "n_jammed": None if jammed_I is None else int(jammed_I.size),
    }
    return CheckReport(
        closure=closure.name, reference=bool(closure.reference),
        parameters=closure.model_dump(mode="json", exclude={"material", "equilibrium"}),
        conditions=results, grid=grid, tolerances=tol.to_dict(), not_finite=not_finite,
    )
