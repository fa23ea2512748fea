"""Implicit pore-gas-pressure block on the MAC grid (paper eq. syst2b; MODEL.md §2; NUMERICS.md §3.3, §8).

Equation (cell centres, gauge pore pressure ``p_f`` [Pa], backward Euler in time):

    (1 - phi^{n+1}) p_f^{n+1}/dt - div(K grad p_f^{n+1}) + p_atm (div u)^{n+1}
        = (1 - phi^n) p_f^n/dt - div((1 - phi) p_f u)^n                                [Pa s^-1]

* :attr:`GasLaw.LINEAR` -- paper eq. syst2b (= pressure-diffusion): ``K = p_atm kappa(phi)``.
* :attr:`GasLaw.NONLINEAR` -- paper eq. pressure-diffusion-nonlinear: ``K = kappa (p_atm + p_f)``,
  lagged at ``p_f^n`` (face value = mean of the two cells), so each step stays linear.
* ``compressibility`` (:class:`granflow.gas.GasCompressibility`, LINEAR law only): the storage
  terms ``(1 - phi) p_f/dt`` (both sides) and the transport are divided by the polytropic index n
  (1 isothermal, the paper's and the default; 1.4 adiabatic), so ``D = n p_atm kappa/(1 - phi)``;
  the gas energy :func:`gas_energy` is divided by n too. n = 1 divides by 1.0: bit-identical.

``kappa(phi) = d^2 (1-phi)^3 / (150 eta_f phi^2)`` [m^2 Pa^-1 s^-1] (Carman-Kozeny, paper eq. beta)
is evaluated at cells with ``phi`` clipped to ``[PHI_FLOOR, phi_max]`` and put on faces by the
HARMONIC mean (series resistances). The transport term is explicit, first-order upwind
(:func:`transport_divergence`); the coupling ``p_atm div u^{n+1}`` is the block
:func:`coupling_block` of the monolithic (u, p, p_f) solve and is absent for a rigid bed.

Boundary conditions (NUMERICS.md §8)
-----------------------------------
* walls and base: impermeable, zero normal Darcy flux (the wall faces carry no flux in
  ``ops.grad``); periodic in x (``grid.periodic_x``) the x-faces all carry flux, through the
  periodic ``ops.grad`` and ``ops.cell_to_face`` (kappa harmonic mean across the periodic face);
* ``dirichlet`` cells (ambient / above a free surface): ``p_f = 0``; their rows become a scaled
  identity and their columns are removed, so the matrix stays symmetric. With the harmonic mean, a
  bed cell next to an ambient cell (``phi -> PHI_FLOOR``: kappa ~6e6 times that at 0.6) sees a face
  mobility ``~2 kappa_bed``, i.e. ``p_f = 0`` effectively at the bed SURFACE (second order), not at
  the ambient cell centre;
* ``open_top=True``: ``p_f = 0`` on the top wall face, by the ghost value ``p_ghost = -p_top``,
  i.e. a face flux ``K_top p_top/(dz/2)`` with ``K_top`` of the top cell;
* ``injection`` ``U_inj`` [m s^-1] (scalar or one value per column): superficial gas velocity
  through the base. Darcy ``q = -kappa grad p_f`` gives ``-kappa dp_f/dz = U_inj`` at ``z = 0``,
  i.e. a source ``p_atm U_inj / dz`` in the bottom cells (``(p_atm + p_f^n) U_inj / dz`` for the
  non-linear law: the injected gas mass flux at the local density) -- it RAISES ``p_f``.
  The steady state of a uniform bed under open top is ``p_f = U_inj (H - z)/kappa`` (exact for the
  discrete scheme); ``U_inj = U_mf = kappa phi rho_s g`` makes ``-dp_f/dz = phi rho_s g``: the gas
  carries the whole weight of the bed (the model's momentum equation has no gas buoyancy).

Energy (paper Theorem th1, eqs H(p), energieA_air; MODEL.md §5; NUMERICS.md §1, §9). For a rigid
bed, with ``E_1 = sum (1-phi) e(p_f) dV`` (:func:`gas_energy`) and the Darcy dissipation
``D = sum_faces w_f kappa_f |grad p_f|^2 dV`` (:func:`darcy_dissipation`):

* NONLINEAR, LOG ``e = (p_atm+p) ln(1+p/p_atm) - p``, ``w_f = 1`` (paper's D): exact (continuous);
* LINEAR, LOG, ``w_f = p_atm/(p_atm + p_f,face)`` (``weighted=True``): exact (continuous);
* LINEAR, QUADRATIC ``e = p^2/(2 p_atm)``, ``w_f = 1``: exact for the DISCRETE scheme, up to the
  backward-Euler loss (below).

LOG is the paper's ``H(p) = (p_atm+p)[ln(1+p/p_atm) - 1]`` plus the constant ``p_atm`` (so e(0) = 0;
constants do not change the balance). The two densities and weights agree to O(p_f/p_atm). For the
linear scheme and QUADRATIC, ``E^{n+1} - E^n + dt D^{n+1} = -sum (1-phi)(p^{n+1}-p^n)^2/(2 p_atm) dV``
(+ ``dt sum U_inj p_f,base dx`` with injection) exactly: backward Euler dissipates O(dt).
"""
from __future__ import annotations

import math
import numbers
import weakref
from enum import Enum
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from granflow.gas import GasCompressibility, GasLaw  # noqa: F401  (re-exported: the solver's gas laws)
from granflow.errors import GranflowInputError
from granflow.grid import Grid
from granflow.materials import Material
from granflow.operators import Operators, product_pairs, sorted_unique

PHI_FLOOR = 1e-3
"""Lower clip of phi in kappa(phi) [-] (kappa diverges as phi -> 0)."""

GHOST_FACE_FACTOR = 2.0
"""Top Dirichlet face: distance cell centre -> face is dz/2, so the flux is 2 K p_top / dz."""


class GasEnergy(Enum):
    """Gas energy density ``e(p_f)`` [J m^-3] of :func:`gas_energy` (pairings: module docstring)."""

    LOG = "log"
    """``(p_atm + p) ln(1 + p/p_atm) - p`` = paper's H(p) + p_atm (eq. H(p))."""
    QUADRATIC = "quadratic"
    """``p^2 / (2 p_atm)``: the exact discrete Lyapunov functional of the LINEAR scheme."""


class GasBlock(NamedTuple):
    """The p_f block of one implicit step: ``matrix @ p_f^{n+1} = explicit_rhs(...) + rhs``."""

    matrix: sp.csr_matrix
    """(n_cells, n_cells) [Pa s^-1 per Pa]: capacity/dt + diffusion, Dirichlet rows scaled identity."""
    rhs: np.ndarray
    """(n_cells,) [Pa s^-1]: boundary sources (base injection), zero in Dirichlet rows."""


# --- argument checks ------------------------------------------------------------------------------
def _cell_field(grid: Grid, name: str, value) -> np.ndarray:
    a = np.asarray(value, dtype=float)
    if a.shape not in (grid.cell_shape, (grid.n_cells,)):
        raise GranflowInputError(f"{name} must have shape {grid.cell_shape}, got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise GranflowInputError(f"{name} must be finite")
    return a.ravel()


def _phi(grid: Grid, phi) -> np.ndarray:
    phi = _cell_field(grid, "phi", phi)
    if np.any(phi < 0.0) or np.any(phi >= 1.0):
        raise GranflowInputError("phi must lie in [0, 1)")
    return phi


def _p_f(grid: Grid, p_f, material: Material, absolute: bool) -> np.ndarray:
    p = _cell_field(grid, "p_f", p_f)
    if absolute and np.any(p <= -material.p_atm):
        raise GranflowInputError("p_f must exceed -p_atm (positive absolute gas pressure)")
    return p


def _dt(dt) -> float:
    if isinstance(dt, bool) or not isinstance(dt, numbers.Real) or math.isnan(dt) or dt <= 0.0:
        raise GranflowInputError(f"dt must be a real number > 0 (inf: steady state), got {dt!r}")
    return float(dt)


def _mask(grid: Grid, dirichlet) -> np.ndarray:
    if dirichlet is None:
        return np.zeros(grid.n_cells, dtype=bool)
    m = np.asarray(dirichlet)
    if m.dtype != bool or m.shape not in (grid.cell_shape, (grid.n_cells,)):
        raise GranflowInputError(f"dirichlet must be a bool mask of shape {grid.cell_shape}, got {m.shape}")
    return m.ravel()


def _injection(grid: Grid, injection) -> np.ndarray:
    u = np.asarray(injection, dtype=float)
    if u.ndim == 0:
        u = np.full(grid.nx, float(u))
    if u.shape != (grid.nx,) or not np.all(np.isfinite(u)):
        raise GranflowInputError(f"injection must be a finite scalar or of shape ({grid.nx},)")
    return u


def _checked(grid, ops, material) -> Operators:
    if not isinstance(grid, Grid):
        raise GranflowInputError(f"grid must be a Grid, got {type(grid).__name__}")
    if not isinstance(material, Material):
        raise GranflowInputError(f"material must be a Material, got {type(material).__name__}")
    if ops is None:
        return Operators.build(grid)
    if not isinstance(ops, Operators) or ops.grid != grid:
        raise GranflowInputError("ops must be the Operators built on the same grid")
    return ops


def _enum(cls: type[Enum], value):
    try:
        return cls(value)
    except ValueError:
        allowed = ", ".join(repr(k.value) for k in cls)
        raise GranflowInputError(f"unknown {cls.__name__} {value!r}; expected one of {allowed}") from None


def polytropic_index(gas: GasLaw, compressibility) -> float:
    """n of :class:`GasCompressibility` [-]; GranflowInputError naming ``gas.compressibility`` for
    an unknown value or ``"adiabatic"`` with a law other than LINEAR."""
    comp = _enum(GasCompressibility, compressibility)
    if comp is not GasCompressibility.ISOTHERMAL and gas is not GasLaw.LINEAR:
        raise GranflowInputError(f'gas.compressibility = "{comp.value}" needs gas.law = "linear" (the '
                                 f'non-linear law is the isothermal state law itself), got {gas.value!r}')
    return comp.polytropic_index


def _top_cells(grid: Grid) -> np.ndarray:
    return np.arange(grid.nx) * grid.nz + grid.nz - 1


def _bottom_cells(grid: Grid, ops: Operators | None = None) -> np.ndarray:
    """The lowest fluid cell of each column: the bottom row, or above a topography's solid cells
    (``ops.solid``, :mod:`granflow.topography`: the gas then enters through the treads)."""
    base = 0 if ops is None or ops.solid is None else np.asarray(ops.solid).reshape(grid.cell_shape).sum(axis=1)
    return np.arange(grid.nx) * grid.nz + base


# --- coefficients ---------------------------------------------------------------------------------
def cell_permeability(phi, material: Material) -> np.ndarray:
    """``kappa(phi)`` [m^2 Pa^-1 s^-1] with ``phi`` clipped to ``[PHI_FLOOR, phi_max]``."""
    return material.permeability(np.clip(np.asarray(phi, dtype=float), PHI_FLOOR, material.phi_max))


def face_permeability(grid: Grid, ops: Operators, phi, material: Material):
    """Mobility at the interior faces (harmonic mean) and on the top wall faces.

    Returns
    -------
    kappa_f : ndarray, (n_unknowns,)
        ``2 k_a k_b / (k_a + k_b)`` of the two cells of each interior face, velocity-vector order.
    kappa_top : ndarray, (nx,)
        kappa of the top cells (the ghost of the open-top condition has the same phi).
    """
    kc = cell_permeability(_phi(grid, phi), material)
    kappa_f = 1.0 / (ops.cell_to_face @ (1.0 / kc))
    return kappa_f, kc[_top_cells(grid)]


# --- assembly -------------------------------------------------------------------------------------
class _DiffusionPattern:
    """``grad^T diag(K) grad`` on a fixed CSR pattern (the diagonal always stored): its data are
    the linear map ``P @ K`` of the face coefficients, built once per operator set, so that each
    step fills an array instead of multiplying sparse matrices (the SaddleAssembler's idea)."""

    def __init__(self, ops: Operators) -> None:
        n = ops.grid.n_cells
        k, r, v = product_pairs(ops.grad, n)
        kd = np.arange(n, dtype=np.int64) * (n + 1)
        keys = sorted_unique(np.concatenate([k, kd]))
        self.n = n
        self.rows, self.cols = (keys // n).astype(np.int64), (keys % n).astype(np.int64)
        self.indptr = np.concatenate([[0], np.cumsum(np.bincount(self.rows, minlength=n))]).astype(np.int64)
        self.indices = self.cols.copy()
        self.diag = np.searchsorted(keys, kd)
        self.P = sp.csr_matrix((v, (np.searchsorted(keys, k), r)), shape=(keys.size, ops.grad.shape[0]))

    def matrix(self, data: np.ndarray) -> sp.csr_matrix:
        return sp.csr_matrix((data, self.indices, self.indptr), shape=(self.n, self.n))


_PATTERNS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
"""Operators -> _DiffusionPattern (dropped with the operators)."""


def _diffusion_pattern(ops: Operators) -> _DiffusionPattern:
    pat = _PATTERNS.get(ops)
    if pat is None:
        pat = _PATTERNS[ops] = _DiffusionPattern(ops)
    return pat


def gas_operator(grid: Grid, ops: Operators | None, phi, dt, material: Material, *,
                 gas: GasLaw | str = GasLaw.LINEAR, p_f=None, dirichlet=None,
                 open_top: bool = False, injection=0.0, face_factor=None, cell_weight=None,
                 compressibility: GasCompressibility | str = GasCompressibility.ISOTHERMAL) -> GasBlock:
    """Matrix and boundary right-hand side of the implicit p_f equation (paper eq. syst2b).

    Parameters
    ----------
    grid : Grid
    ops : Operators or None
        Operators of ``grid`` (built if None).
    phi : array_like, (nx, nz) or (n_cells,)
        Packing ``phi^{n+1}`` [-] (capacity ``1 - phi`` and kappa).
    dt : float
        Time step [s] > 0; ``math.inf`` assembles the steady problem (needs a Dirichlet condition).
    material : Material
        Supplies d, eta_f, p_atm, phi_max.
    gas : GasLaw or str
        LINEAR (``K = p_atm kappa``) or NONLINEAR (``K = kappa (p_atm + p_f^n)``, needs ``p_f``).
    p_f : array_like, optional
        ``p_f^n`` [Pa], used only by NONLINEAR (lagged coefficient and injected mass flux).
    dirichlet : bool array, (nx, nz), optional
        Cells where ``p_f = 0`` (ambient / above the bed).
    open_top : bool
        ``p_f = 0`` on the top wall face (ghost ``p_ghost = -p_top``). Otherwise impermeable.
    injection : float or array_like (nx,)
        Superficial gas velocity ``U_inj`` [m s^-1] injected through the base (``>0`` upwards).
    face_factor : array_like (n_unknowns,), optional
        Multiplier of the face mobilities (the indicator surface's faces to the surface,
        :meth:`granflow.model.Model.gas_face_factor`); pass the same to :func:`darcy_dissipation`.
    compressibility : GasCompressibility or str
        ``"isothermal"`` (default, n = 1) or ``"adiabatic"`` (n = 1.4, LINEAR only): the capacity
        is ``(1 - phi)/(n dt)`` (module docstring).
    cell_weight : array_like (n_cells,), optional
        Multiplier of every cell's own terms (capacity, open-top face, injection): the rings'
        circumferences ``2 pi r_c`` of an axisymmetric grid, whose face weights ``2 pi r_f``
        come in ``face_factor`` (:class:`granflow.physics.coupling.GasCoupling`).

    Returns
    -------
    GasBlock
        ``matrix = diag((1-phi)/(n dt)) + grad^T diag(K_f) grad`` (+ top-face term), symmetric, with
        Dirichlet rows/columns replaced by a scaled identity; ``rhs`` = base-injection source
        ``K_b U_inj/(kappa_b dz)`` [Pa s^-1] (``K_b/kappa_b = p_atm`` or ``p_atm + p_f^n``).
    """
    ops = _checked(grid, ops, material)
    gas, dt = _enum(GasLaw, gas), _dt(dt)
    n_poly = polytropic_index(gas, compressibility)
    phi = _phi(grid, phi)
    mask = _mask(grid, dirichlet)
    u_inj = _injection(grid, injection)
    gauge_faces, gauge_base = _gauges(grid, ops, gas, p_f, material)
    if math.isinf(dt) and not (open_top or mask.any()):
        raise GranflowInputError("dt = inf (steady state) needs dirichlet cells or open_top")

    kappa_f, kappa_top = face_permeability(grid, ops, phi, material)
    if face_factor is not None:
        kappa_f = kappa_f * np.asarray(face_factor, dtype=float)
    K_f = kappa_f * (material.p_atm + gauge_faces)
    pat = _diffusion_pattern(ops)
    data = pat.P @ K_f
    weight = 1.0 if cell_weight is None else np.asarray(cell_weight, dtype=float)
    data[pat.diag] += weight * (1.0 - phi) / (n_poly * dt)  # capacity
    if open_top:
        top = np.zeros(grid.n_cells)
        top[_top_cells(grid)] = GHOST_FACE_FACTOR * material.p_atm * kappa_top / grid.dz**2
        data[pat.diag] += weight * top
    rhs = np.zeros(grid.n_cells)
    rhs[_bottom_cells(grid, ops)] = (material.p_atm + gauge_base) * u_inj / grid.dz
    rhs = weight * rhs
    if mask.any():
        keep = (~mask).astype(float)
        scale = float(data[pat.diag][~mask].mean()) if (~mask).any() else 1.0
        data *= keep[pat.rows] * keep[pat.cols]  # Dirichlet rows and columns -> scaled identity
        data[pat.diag] += mask * scale
        rhs[mask] = 0.0
    return GasBlock(pat.matrix(data), rhs)


def _gauges(grid: Grid, ops: Operators, gas: GasLaw, p_f, material: Material):
    """``(p_f^n at the faces, p_f^n of the base cells)`` of the NONLINEAR law's lagged coefficient
    and injected mass flux (0, 0 for LINEAR)."""
    if gas is not GasLaw.NONLINEAR:
        return 0.0, 0.0
    if p_f is None:
        raise GranflowInputError("gas='nonlinear' needs p_f (the lagged p_f^n)")
    p_old = _p_f(grid, p_f, material, absolute=True)
    return ops.cell_to_face @ p_old, p_old[_bottom_cells(grid, ops)]


def explicit_rhs(grid: Grid, phi_old, p_f_old, dt, *, transport=None, dirichlet=None,
                 polytropic: float = 1.0) -> np.ndarray:
    """History part of the right-hand side, ``[(1 - phi^n) p_f^n/dt - div((1-phi) p_f u)^n] / n``
    [Pa s^-1], n = ``polytropic`` (:func:`polytropic_index`; 1 isothermal).

    ``transport`` is the cell array of :func:`transport_divergence` (None: rigid bed). Zero in
    Dirichlet cells and for ``dt = inf``.
    """
    dt = _dt(dt)
    phi_old = _phi(grid, phi_old)
    p_old = _cell_field(grid, "p_f", p_f_old)
    rhs = np.zeros(grid.n_cells) if math.isinf(dt) else (1.0 - phi_old) * p_old / dt
    if transport is not None:
        rhs = rhs - _cell_field(grid, "transport", transport)
    rhs = rhs / polytropic
    rhs[_mask(grid, dirichlet)] = 0.0
    return rhs


def transport_divergence(grid: Grid, ops: Operators, phi, p_f, vel, div=None) -> np.ndarray:
    """``div((1 - phi) p_f u)`` at cells [Pa s^-1], first-order upwind, zero flux through walls
    (periodic in x: the x-face 0 takes its upwind value from cell nx - 1 or 0).

    ``phi`` [-], ``p_f`` [Pa]: cell fields at ``t^n``; ``vel``: velocity unknowns at ``t^n`` [m s^-1];
    ``div`` the divergence to take (default ``ops.div``; an axisymmetric grid's, with r).
    """
    q = ((1.0 - _phi(grid, phi)) * _cell_field(grid, "p_f", p_f)).reshape(grid.cell_shape)
    u, w = grid.unpack_velocity(vel)
    ui, wi = u[grid.u_columns, :], w[:, 1:-1]
    q_west, q_east = (np.roll(q, 1, axis=0), q) if grid.periodic_x else (q[:-1, :], q[1:, :])
    flux_x = ui * np.where(ui > 0.0, q_west, q_east)
    flux_z = wi * np.where(wi > 0.0, q[:, :-1], q[:, 1:])
    return (ops.div if div is None else div) @ np.concatenate([flux_x.ravel(), flux_z.ravel()])


def coupling_block(ops: Operators, material: Material, dirichlet=None) -> sp.csr_matrix:
    """``p_atm div`` (n_cells x n_unknowns) [Pa m^-1]: the ``p_atm (div u)^{n+1}`` term of the p_f
    rows in a monolithic solve; rows of Dirichlet cells are zero."""
    keep = sp.diags((~_mask(ops.grid, dirichlet)).astype(float))
    return sp.csr_matrix(material.p_atm * (keep @ ops.div))


# --- rigid-bed step -------------------------------------------------------------------------------
class PorePressureStep:
    """Backward-Euler step of the p_f equation for a RIGID bed (``u = 0``).

    The LU factorisation (``scipy.sparse.linalg.splu``) is reused while ``phi`` and ``dt`` are
    unchanged (LINEAR law only; the NONLINEAR coefficient depends on ``p_f^n``, so every step
    re-factorises). Options are those of :func:`gas_operator`.

    Examples
    --------
    >>> import numpy as np
    >>> g = Grid(nx=2, nz=20, Lx=0.01, Lz=0.1)
    >>> step = PorePressureStep(g, Material(d=70e-6), open_top=True)
    >>> phi = np.full(g.cell_shape, 0.6)
    >>> p = step(np.full(g.cell_shape, 1000.0), phi, 1e-3)
    >>> bool(p[0, 0] < 1000.0), step.n_factorisations
    (True, 1)
    """

    def __init__(self, grid: Grid, material: Material, ops: Operators | None = None, *,
                 gas: GasLaw | str = GasLaw.LINEAR, dirichlet=None, open_top: bool = False,
                 injection=0.0,
                 compressibility: GasCompressibility | str = GasCompressibility.ISOTHERMAL) -> None:
        if getattr(grid, "axisymmetric", False):
            raise GranflowInputError("PorePressureStep is plane (per unit width); an axisymmetric grid's gas rows "
                                     "are weighted by the rings (granflow.physics.coupling.GasCoupling)")
        self.ops = _checked(grid, ops, material)
        self.grid, self.material, self.gas = grid, material, _enum(GasLaw, gas)
        self.compressibility = _enum(GasCompressibility, compressibility)
        self.polytropic = polytropic_index(self.gas, self.compressibility)
        self.dirichlet = _mask(grid, dirichlet).copy()
        self.open_top = bool(open_top)
        self.injection = _injection(grid, injection).copy()
        self.n_factorisations = 0
        self._key: tuple[bytes, float] | None = None
        self._lu = None
        self._rhs_bc: np.ndarray | None = None

    def __call__(self, p_f, phi, dt) -> np.ndarray:
        """``p_f^{n+1}`` [Pa], shape ``(nx, nz)``, from ``p_f^n`` [Pa], rigid ``phi`` [-], ``dt`` [s]."""
        dt = _dt(dt)
        phi = _phi(self.grid, phi)
        p_old = _p_f(self.grid, p_f, self.material, absolute=self.gas is GasLaw.NONLINEAR)
        key = (phi.tobytes(), dt)
        if self.gas is GasLaw.NONLINEAR or key != self._key:
            block = gas_operator(self.grid, self.ops, phi, dt, self.material, gas=self.gas,
                                 p_f=p_old, dirichlet=self.dirichlet, open_top=self.open_top,
                                 injection=self.injection, compressibility=self.compressibility)
            self._lu = splu(sp.csc_matrix(block.matrix))
            self._rhs_bc, self._key = block.rhs, key
            self.n_factorisations += 1
        rhs = explicit_rhs(self.grid, phi, p_old, dt, dirichlet=self.dirichlet,
                           polytropic=self.polytropic) + self._rhs_bc
        return self._lu.solve(rhs).reshape(self.grid.cell_shape)

    step = __call__


def step_static(grid: Grid, phi, p_f, dt, material: Material, ops: Operators | None = None,
                **options) -> np.ndarray:
    """One rigid-bed step ``p_f^n -> p_f^{n+1}`` [Pa]; ``options`` as :class:`PorePressureStep`."""
    return PorePressureStep(grid, material, ops, **options)(p_f, phi, dt)


# --- energy ---------------------------------------------------------------------------------------
def gas_energy(grid: Grid, phi, p_f, material: Material,
               density: GasEnergy | str = GasEnergy.LOG, polytropic: float = 1.0) -> float:
    """``E_1 = sum (1 - phi) e(p_f) dV / n`` [J m^-1] (per unit width; paper eq. H(p), MODEL.md §5).

    ``density`` LOG: ``e = (p_atm + p) ln(1 + p/p_atm) - p``; QUADRATIC: ``p^2/(2 p_atm)``
    (pairings with :func:`darcy_dissipation` in the module docstring); n = ``polytropic``
    (:func:`polytropic_index`; 1 isothermal): the storage of the adiabatic gas is n times smaller.
    """
    density = _enum(GasEnergy, density)
    phi = _phi(grid, phi)
    p = _p_f(grid, p_f, material, absolute=density is GasEnergy.LOG)
    pa = material.p_atm
    if density is GasEnergy.LOG:
        e = (pa + p) * np.log1p(p / pa) - p
    else:
        e = p**2 / (2.0 * pa)
    if getattr(grid, "axisymmetric", False):  # over the rings [J]
        return float(np.sum((1.0 - phi) * e * grid.cell_volumes.ravel()) / polytropic)
    return float(np.sum((1.0 - phi) * e) * grid.cell_volume / polytropic)


def darcy_dissipation(grid: Grid, ops: Operators, phi, p_f, material: Material, *,
                      open_top: bool = False, weighted: bool = False, face_factor=None,
                      cell_weight=None) -> float:
    """``D = sum_faces w_f kappa_f |grad p_f|^2 dV`` [W m^-1] (paper eq. energieA_air, NUMERICS §9).

    Interior faces count with ``dV``; with ``open_top`` each top wall face adds
    ``kappa_top (2 p_top/dz)^2 dV/2`` (the half cell between the centre and the Dirichlet face),
    which makes ``D`` the exact discrete partner of :func:`gas_operator`. ``p_f`` must already be 0
    in Dirichlet cells. ``weighted=False``: ``w_f = 1`` (paper's D); ``weighted=True``:
    ``w_f = p_atm/(p_atm + p_f,face)`` (partner of the LOG energy for the LINEAR law).
    ``face_factor``, ``cell_weight``: the multipliers of the face mobilities and of the cells'
    own terms given to :func:`gas_operator`.
    """
    ops = _checked(grid, ops, material)
    p = _p_f(grid, p_f, material, absolute=weighted)
    kappa_f, kappa_top = face_permeability(grid, ops, phi, material)
    if face_factor is not None:
        kappa_f = kappa_f * np.asarray(face_factor, dtype=float)
    grad = ops.grad @ p
    w_f = material.p_atm / (material.p_atm + ops.cell_to_face @ p) if weighted else 1.0
    total = np.sum(w_f * kappa_f * grad**2) * grid.cell_volume
    if open_top:
        g_top = GHOST_FACE_FACTOR * p[_top_cells(grid)] / grid.dz   # w_f = 1: p_f = 0 on the face
        w_top = 1.0 if cell_weight is None else np.asarray(cell_weight, dtype=float)[_top_cells(grid)]
        total += np.sum(w_top * kappa_top * g_top**2) * grid.cell_volume / GHOST_FACE_FACTOR
    return float(total)
