"""Linear solvers (granflow.solvers): the block-AMG saddle-point solver against SuperLU on
systems assembled by the real Model, SA-AMG + CG on a variable-coefficient Poisson problem, the
registry, reuse and failure paths.

Independent references: ``scipy.sparse.linalg.spsolve`` (SuperLU, a different algorithm) on the
same matrices; matrices captured from :meth:`granflow.model.Model.advance` (the solve call is
intercepted, nothing is re-implemented); the Poisson matrix is assembled here from its 5-point
stencil. Tolerances: FGMRES/CG run to a relative residual of 1e-10 (scaled system), and must
reproduce the direct solution to 1e-6 relative in u and in p (observed 1e-9 .. 1e-7).
"""
from __future__ import annotations

import functools
import types

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

import granflow.model as gm
import granflow.step as gstep
from granflow.errors import GranflowInputError
from granflow.grid import Grid
from granflow.model import Model
from granflow.rheology import make_closure
from granflow.simulation import Simulation
from granflow.solvers import (LINEAR_SOLVERS, LinearSolverError, MatrixChange, SaddleHints,
                              make_linear_solver, pardiso_available, velocity_near_nullspace)
from granflow.state import State

PHI_MAX = 0.6
MATERIAL = dict(d=70e-6, rho_s=2500.0, phi_max=PHI_MAX)
RTOL = 1e-10
ACCURACY = 1e-6            # relative error of u and p against the direct solution
LEVELS = (1, 2, 4)         # grid refinement factors
MID_COLLAPSE_TIME = 0.05   # s
ITERATION_CAP = 40         # FGMRES iterations; measured 14-27 (augmented 14-26, CC 22-26, LSC 17-27)
GRID_INDEPENDENCE = 2.0    # max/min of the mean iterations over the three resolutions


V1 = dict(surface="threshold", advection="upwind")
"""The v1 schemes, pinned for the mid-collapse systems (see :func:`collapse_systems`)."""


def dp_model(nx: int, nz: int, Lx: float, Lz: float, **options) -> Model:
    clo = make_closure("drucker_prager", material=MATERIAL, delta_deg=26.74)
    # systems on the whole grid (the AMG's velocity vector): no velocity band; the Picard loop
    # (the fixtures capture a step's sweeps)
    options.setdefault("picard", {"max_sweeps": 10, "predictor": "previous"})
    return Model(Grid(nx=nx, nz=nz, Lx=Lx, Lz=Lz), clo, ambient={"velocity_band": 0}, **options)


# --------------------------------------------------------------------------------------------
# Capture of the systems assembled by Model.advance (read-only use of the Model)
# --------------------------------------------------------------------------------------------
def capture(model: Model, state: State, dt: float) -> list[dict]:
    """Advance ``state`` by one step and return every linear system the Model solved:
    matrix, rhs, the direct solution, the Cahouet-Chabard hints (the diagonal inertia part of the
    velocity block as passed to ``SaddleAssembler.velocity_data``, eta_c at the active cells in
    matrix order) and the full cell viscosity. Only calls are intercepted (pass-through).
    The wall-pressure base friction (``base_friction="wall"``, the default of the indicator
    surface) evaluates the closure a second time per sweep, for the base cells only
    (:func:`granflow.step.base_node_viscosity`); that call is not the sweep's and is not
    recorded."""
    systems, coefs, actives, masses = [], [], [], []
    asm = model.assembler
    orig_coef, orig_saddle, orig_vdata = model.coefficients, asm.saddle, asm.velocity_data
    orig_base = gstep.base_node_viscosity
    in_base = []

    def coefficients(*args, **kwargs):
        out = orig_coef(*args, **kwargs)
        if not in_base:
            coefs.append(out)
        return out

    def base_node_viscosity(*args, **kwargs):
        in_base.append(True)
        try:
            return orig_base(*args, **kwargs)
        finally:
            in_base.pop()

    def velocity_data(rho_over_dt, *args, **kwargs):
        masses.append(np.array(rho_over_dt, dtype=float))
        return orig_vdata(rho_over_dt, *args, **kwargs)

    def saddle(a_data, active, *args, **kwargs):
        actives.append(np.array(active, dtype=bool))
        return orig_saddle(a_data, active, *args, **kwargs)

    def spsolve(K, rhs):
        x = spla.spsolve(K, rhs)
        systems.append(dict(K=K.copy(), rhs=np.array(rhs), x=x))
        return x

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(model, "coefficients", coefficients)
        mp.setattr(asm, "saddle", saddle)
        mp.setattr(asm, "velocity_data", velocity_data)
        mp.setattr(gstep, "base_node_viscosity", base_node_viscosity)
        mp.setattr(gstep, "spla", types.SimpleNamespace(spsolve=spsolve))
        report = model.advance(state, dt)
    assert not report.failed, report.message
    assert len(systems) == len(coefs) == len(actives) == len(masses) >= 1
    for s, c, a, mass in zip(systems, coefs, actives, masses):
        s.update(hints=SaddleHints(mass=mass, viscosity=gstep.hint_viscosity(model, c.eta_c[a])), eta_c=c.eta_c,
                 n=model.grid.n_unknowns, grid=model.grid)
    return systems


def refine(state: State, coarse: Grid, fine: Grid) -> State:
    """Piecewise-constant phi and p, bilinear face velocities, on a grid ``r`` times finer."""
    from scipy.interpolate import RegularGridInterpolator
    r = fine.nx // coarse.nx
    rep = lambda a: np.repeat(np.repeat(a, r, 0), r, 1)  # noqa: E731
    u, w = coarse.unpack_velocity(state.vel)
    out = State.at_rest(fine, rep(state.phi), p=rep(state.p))
    vel = []
    for comp, (Xc, Zc), (Xf, Zf) in ((u, coarse.xface_coords(), fine.xface_coords()),
                                     (w, coarse.zface_coords(), fine.zface_coords())):
        f = RegularGridInterpolator((Xc[:, 0], Zc[0]), comp, bounds_error=False, fill_value=None)
        vel.append(f(np.stack([Xf, Zf], axis=-1)))
    vel[0][[0, -1], :] = 0.0
    vel[1][:, [0, -1]] = 0.0
    out.vel = fine.pack_velocity(*vel)
    return out


def column(model: Model) -> np.ndarray:
    X, Z = model.grid.cell_coords()
    return np.where((X < 0.1) & (Z < 0.1), PHI_MAX, 0.0)


@pytest.fixture(scope="module")
def static_systems():
    """Uniform layer (phi_max, H = 7 cm) in a 0.2 x 0.1 m box, first step from rest with the
    lithostatic first iterate, at 20x10, 40x20, 80x40 cells."""
    out = {}
    for r in LEVELS:
        model = dp_model(20 * r, 10 * r, 0.2, 0.1)
        Z = model.grid.cell_coords()[1]
        out[r] = capture(model, model.initial_state(np.where(Z < 0.07, PHI_MAX, 0.0)), 1e-3 / r)
    return out


@pytest.fixture(scope="module")
def collapse_systems():
    """10 x 10 cm column in a 0.4 x 0.15 m box. 'onset': first step from rest (regularised
    plasticity, eta from 1e-3 in the ambient to 5e4 Pa s); 'mid': the state at t = 0.05 s of a
    40x15 run, refined to 40x15, 80x30, 160x60, one settling step, then the captured step
    (dt = 1 ms / r).

    'onset' uses the defaults (scheme v2). 'mid' pins the v1 schemes (``V1``): under v2 the
    refined 160x60 mid-collapse systems are not solved grid-independently by the AMG (measured
    3 Dec 2026, FGMRES iterations per sweep at 40x15 / 80x30 / 160x60: augmented 19 / 17-18 /
    45-63, Cahouet-Chabard 28 / 25-26 / 55-110, LSC 19-20 / 21 / 55-113; refining c from below
    instead of phi piecewise-constant made 160x60 fail at 300 iterations) -- an open issue of the
    AMG with the indicator surface, not of this fixture. 'mid_v2' keeps the v2 systems at 40x15
    and 80x30, where the AMG is as good as with v1."""
    out = {"mid": {}, "mid_v2": {}}
    for key, options, levels in (("mid", V1, LEVELS), ("mid_v2", {}, LEVELS[:2])):
        coarse = dp_model(40, 15, 0.4, 0.15, **options)
        state = coarse.initial_state(column(coarse))
        Simulation(coarse, state, stop_time=MID_COLLAPSE_TIME).run()
        for r in levels:
            model = dp_model(40 * r, 15 * r, 0.4, 0.15, **options)
            fine = refine(state, coarse.grid, model.grid)
            model.advance(fine, 1e-3 / r)
            out[key][r] = capture(model, fine, 1e-3 / r)
    return out


@functools.cache
def onset_systems(r: int) -> list[dict]:
    """The 'onset' systems of :func:`collapse_systems` at refinement ``r`` (defaults, scheme v2),
    built on first use: only the viscosity-contrast test reads them, and 160x60 only when slow."""
    model = dp_model(40 * r, 15 * r, 0.4, 0.15)
    return capture(model, model.initial_state(column(model)), 1e-3 / r)


def errors(x, ref, n: int, u_floor: float = 0.0) -> tuple[float, float]:
    """Relative 2-norm errors of the velocity (floor ``u_floor`` on the norm) and pressure."""
    eu = np.linalg.norm(x[:n] - ref[:n]) / max(np.linalg.norm(ref[:n]), u_floor)
    ep = np.linalg.norm(x[n:] - ref[n:]) / np.linalg.norm(ref[n:])
    return float(eu), float(ep)


def run_amg(systems_by_level: dict, schur: str) -> dict:
    """Solve every captured system with one 'amg' solver per level (hierarchies reused across
    the sweeps); return (iterations, u error, p error, info) per system."""
    table = {}
    for r, systems in systems_by_level.items():
        solver = make_linear_solver("amg", grid=systems[0]["grid"], schur=schur, rtol=RTOL)
        rows = []
        for s in systems:
            hints = None if schur == "lsc" else s["hints"]
            x, info = solver.solve(s["K"], s["rhs"], hints=hints)
            rows.append((info.iterations, *errors(x, s["x"], s["n"]), info))
        table[r] = rows
    return table


# --------------------------------------------------------------------------------------------
# Saddle-point systems of the solver
# --------------------------------------------------------------------------------------------
def _assert_accurate(table) -> None:
    """Every solve of a run_amg table within ACCURACY of the direct one, converged, <= ITERATION_CAP."""
    for rows in table.values():
        for its, eu, ep, info in rows:
            assert eu <= ACCURACY and ep <= ACCURACY, (eu, ep)
            assert info.converged and info.scaled_residual <= RTOL * (1 + 1e-6)
            assert its <= ITERATION_CAP


@pytest.mark.parametrize("schur", ["augmented", "cahouet_chabard", "lsc"])
def test_amg_reproduces_direct_mid_collapse_grid_independently(collapse_systems, schur):
    """Mid-collapse systems at 3 resolutions (1.2e3 .. 2e4 unknowns, every Picard sweep):
    errors <= 1e-6 in u and p; iterations <= 40 and max/min over resolutions <= 2 for the three
    Schur approximations (measured: augmented 18, 15, 15; Cahouet-Chabard 26, 23, 22; LSC 17,
    18, 27). v1 schemes pinned (collapse_systems: under v2 the 160x60 systems need 45-113)."""
    table = run_amg(collapse_systems["mid"], schur)
    print(f"\n{schur} mid-collapse iterations per sweep: "
          + "; ".join(f"{40 * r}x{15 * r}: {[row[0] for row in rows]}" for r, rows in table.items()))
    _assert_accurate(table)
    per_level = [np.mean([row[0] for row in rows]) for rows in table.values()]
    assert max(per_level) <= GRID_INDEPENDENCE * min(per_level), per_level


@pytest.mark.parametrize("schur", ["augmented", "cahouet_chabard", "lsc"])
def test_amg_reproduces_direct_mid_collapse_v2(collapse_systems, schur):
    """Scheme v2 (defaults) mid-collapse systems at 40x15 and 80x30 (every Picard sweep): errors
    <= 1e-6, iterations <= 40 (measured 3 Dec 2026: augmented 19, 17-18; Cahouet-Chabard 28,
    25-26; LSC 19-20, 21). At 160x60 v2 needs 45-113 iterations (collapse_systems docstring)."""
    table = run_amg(collapse_systems["mid_v2"], schur)
    print(f"\nv2 {schur} mid-collapse iterations per sweep: "
          + "; ".join(f"{40 * r}x{15 * r}: {[row[0] for row in rows]}" for r, rows in table.items()))
    _assert_accurate(table)


def test_amg_reproduces_direct_on_a_static_layer(static_systems):
    """Static layer (the exact discrete solution is u = 0, p lithostatic): the velocity error is
    measured against the creep scale eps H sqrt(n) (the direct u is round-off); p to 1e-6.
    Default (augmented) preconditioner: iterations <= 40, max/min <= 2 (measured 18, 20, 23;
    without the augmentation 32, 50, 75: the case that motivated it, see saddle.py)."""
    model_eps, H = gm.DEFAULT_EPS, 0.07
    table = {}
    for r, systems in static_systems.items():
        solver = make_linear_solver("amg", grid=systems[0]["grid"], rtol=RTOL)
        rows = []
        for s in systems:
            x, info = solver.solve(s["K"], s["rhs"], hints=s["hints"])
            floor = model_eps * H * np.sqrt(s["n"])
            rows.append((info.iterations, *errors(x, s["x"], s["n"], floor)))
        table[r] = rows
    print("\nstatic layer iterations: " + "; ".join(f"{20 * r}x{10 * r}: {[row[0] for row in rows]}"
                                                   for r, rows in table.items()))
    for rows in table.values():
        for its, eu, ep in rows:
            assert eu <= ACCURACY and ep <= ACCURACY, (eu, ep)
            assert its <= ITERATION_CAP
    per_level = [np.mean([row[0] for row in rows]) for rows in table.values()]
    assert max(per_level) <= GRID_INDEPENDENCE * min(per_level), per_level


@pytest.mark.parametrize("levels", [LEVELS[:2], pytest.param(LEVELS, marks=pytest.mark.slow)],
                         ids=["40x15-80x30", "40x15-160x60"])
def test_amg_handles_a_viscosity_contrast_above_1e6(levels):
    """Onset of the collapse (first step from rest, 40x15 .. 160x60; CI: 40x15 and 80x30, the
    160x60 solves were most of this test's time): regularised yield
    viscosity Z p / (2 eps) next to the ambient eta_a = 1e-3 Pa s (contrast asserted >= 1e6) and a
    velocity-block diagonal spanning >= 1e5. Errors <= 1e-6; iterations <= 40, max/min <= 2
    (measured 19, 21, 28 with the default augmented preconditioner)."""
    means = []
    for r in levels:
        systems = onset_systems(r)
        solver = make_linear_solver("amg", grid=systems[0]["grid"], rtol=RTOL)
        its = []
        for s in systems:
            eta = s["eta_c"]
            diag = s["K"].diagonal()[:s["n"]]
            assert eta.max() / eta.min() >= 1e6 and diag.max() / diag.min() >= 1e5
            x, info = solver.solve(s["K"], s["rhs"], hints=s["hints"])
            eu, ep = errors(x, s["x"], s["n"])
            assert eu <= ACCURACY and ep <= ACCURACY, (eu, ep)
            assert info.iterations <= ITERATION_CAP
            its.append(info.iterations)
        means.append(np.mean(its))
        print(f"\nonset {40 * r}x{15 * r} (eta contrast {eta.max() / eta.min():.1e}): iterations {its}")
    assert max(means) <= GRID_INDEPENDENCE * min(means), means


def test_warm_start_reuse_and_unchanged_matrix(collapse_systems):
    """x0 = the exact solution needs no iteration; ``change='none'`` keeps both hierarchies
    (no set-up) and gives the same iterations; the next sweep (new values, reused aggregates)
    still converges to the direct solution."""
    systems = collapse_systems["mid"][2]
    solver = make_linear_solver("amg", grid=systems[0]["grid"], rtol=RTOL)
    s0 = systems[0]
    x, first = solver.solve(s0["K"], s0["rhs"], hints=s0["hints"])
    _, again = solver.solve(s0["K"], s0["rhs"], hints=s0["hints"], change=MatrixChange.NONE)
    assert not again.rebuilt and again.iterations == first.iterations
    _, warm = solver.solve(s0["K"], s0["rhs"], x0=s0["x"], hints=s0["hints"], change="none")
    assert warm.iterations <= 1
    refreshes = solver.velocity.refreshes
    for s in systems[1:]:
        x0 = np.zeros(s["K"].shape[0])
        x0[:s["n"]] = x[:s["n"]]                  # previous sweep's velocity, p from zero
        x, info = solver.solve(s["K"], s["rhs"], x0=x0, hints=s["hints"])
        assert max(errors(x, s["x"], s["n"])) <= ACCURACY
    assert solver.velocity.refreshes > refreshes  # same pattern: aggregates kept, values refreshed


def test_amg_on_a_bordered_pore_pressure_system(collapse_systems):
    """Forward compatibility with the 3x3 block [[A, G, G_w], [G^T, -C, 0], [G_w^T, 0, -M]]
    (p_f rows in the symmetric form of NUMERICS.md §3.1: M = (1-phi)/(p_atm dt) + G_w^T kappa
    G_w, wet = dense cells): amg with and without hints matches the direct solve to 1e-6."""
    s = collapse_systems["mid"][1][-1]
    model = dp_model(40, 15, 0.4, 0.15)
    ops, n = model.ops, s["n"]
    K = s["K"]
    m = K.shape[0] - n
    wet = np.flatnonzero(s["eta_c"] > 2 * model.ambient.eta_a)
    Gw = ops.grad[:, wet]
    p_atm, dt, kappa = 1.0e5, 1e-3, 5.0e-7  # Pa, s, m^2 Pa^-1 s^-1
    M = sp.diags(np.full(wet.size, (1 - PHI_MAX) / (p_atm * dt))) + Gw.T @ (kappa * Gw)
    big = model.assembler.bordered(K, Gw, Gw.T, -M)
    rng = np.random.default_rng(1)
    rhs = np.concatenate([s["rhs"], rng.standard_normal(wet.size) * np.abs(s["rhs"][n:]).mean()])
    ref = spla.spsolve(big.tocsc(), rhs)
    for hints in (s["hints"], None):
        solver = make_linear_solver("amg", grid=model.grid, rtol=RTOL)
        x, info = solver.solve(big, rhs, hints=hints)
        assert np.linalg.norm(x[:n] - ref[:n]) <= ACCURACY * np.linalg.norm(ref[:n])
        for part in (slice(n, n + m), slice(n + m, None)):
            assert np.linalg.norm(x[part] - ref[part]) <= ACCURACY * np.linalg.norm(ref[part])
        print(f"\nbordered (u, p, p_f), hints={hints is not None}: {info.iterations} iterations")


# --------------------------------------------------------------------------------------------
# Poisson, direct solver, registry, failures
# --------------------------------------------------------------------------------------------
def variable_poisson(n: int) -> tuple[sp.csr_matrix, np.ndarray]:
    """-div(k grad q) on the unit square, n x n cells, Dirichlet q = 0 outside (ghost cells),
    k = 1e-3 in a disc of radius 0.3 and 1 elsewhere (the 1/rho contrast of NUMERICS.md §3.2)."""
    h = 1.0 / n
    xc = (np.arange(n) + 0.5) * h
    X, Y = np.meshgrid(xc, xc, indexing="ij")
    k = np.where((X - 0.5) ** 2 + (Y - 0.5) ** 2 < 0.09, 1e-3, 1.0)
    kp = np.pad(k, 1, mode="edge")
    idx = np.arange(n * n).reshape(n, n)
    rows, cols, vals = [], [], []
    diag = np.zeros((n, n))
    for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1)):
        kn = kp[1 + di:n + 1 + di, 1 + dj:n + 1 + dj]
        kf = 2.0 * k * kn / (k + kn) / h**2                      # harmonic face coefficient
        diag += kf
        inside = np.zeros((n, n), dtype=bool)
        inside[max(-di, 0):n - max(di, 0), max(-dj, 0):n - max(dj, 0)] = True
        rows.append(idx[inside])
        cols.append(np.roll(np.roll(idx, -di, 0), -dj, 1)[inside])
        vals.append(-kf[inside])
    rows.append(idx.ravel())
    cols.append(idx.ravel())
    vals.append(diag.ravel())
    A = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n * n,) * 2)
    b = np.sin(np.pi * X).ravel() * (1.0 + Y.ravel())
    return A, b


@pytest.mark.parametrize("sizes", [(32, 64, 128), pytest.param((64, 128, 256), marks=pytest.mark.slow)],
                         ids=["32-128", "64-256"])
def test_amg_cg_solves_a_variable_coefficient_poisson_problem(sizes):
    """SA-AMG + CG (rtol 1e-10) agrees with spsolve to 1e-7 relative; iterations <= 25 at three
    sizes refined by 2 and 4, max/min <= 2: 32^2-128^2 in CI, 64^2-256^2 slow (the 256^2 spsolve
    reference was most of this test's CI time)."""
    its = []
    for n in sizes:
        A, b = variable_poisson(n)
        assert abs(A - A.T).max() == 0.0
        x, info = make_linear_solver("amg_cg", rtol=RTOL).solve(A, b)
        ref = spla.spsolve(A.tocsc(), b)
        assert np.linalg.norm(x - ref) <= 1e-7 * np.linalg.norm(ref)
        assert info.residual <= 1.01 * RTOL
        its.append(info.iterations)
    print(f"\nPoisson SA+CG iterations at {sizes}^2: {its}")
    assert max(its) <= 25 and max(its) <= GRID_INDEPENDENCE * min(its)


def test_direct_solver_reuses_the_factorisation_only_for_an_unchanged_matrix():
    A, b = variable_poisson(16)
    solver = make_linear_solver("direct")
    x1, i1 = solver.solve(A, b)
    x2, i2 = solver.solve(A.copy(), 2 * b)                     # same values: detected
    assert i1.rebuilt and not i2.rebuilt and np.allclose(x2, 2 * x1, rtol=1e-12, atol=0)
    x3, i3 = solver.solve(A * 2.0, b)                           # new values: refactorised
    assert i3.rebuilt and np.allclose(x3, 0.5 * x1, rtol=1e-12, atol=0)
    _, i4 = solver.solve(A * 2.0, b, change=MatrixChange.NONE)
    assert not i4.rebuilt and i4.residual <= 1e-12



@pytest.mark.parametrize("name", ["direct", "pardiso"])
def test_the_reported_error_is_the_solution_s_residual_vector(name):
    """``SolveInfo.error`` (which the step books as the solve's error instead of multiplying
    again) is ``A x - b`` of the returned ``x``, recomputed here with SciPy; its norm is the
    reported relative residual. The Krylov solvers report None."""
    if name == "pardiso" and not pardiso_available():
        pytest.skip("pypardiso / MKL not installed")
    A, b = variable_poisson(16)
    x, info = make_linear_solver(name).solve(A, b)
    r = A @ x - b
    assert info.error is not None and info.error.shape == b.shape
    assert np.abs(info.error - r).max() <= 1e-12 * np.abs(A @ x).max()
    assert info.residual == pytest.approx(np.linalg.norm(r) / np.linalg.norm(b), rel=1e-6, abs=1e-300)
    _, cg = make_linear_solver("amg_cg").solve(A, b)
    assert cg.error is None

def test_registry_parameters_and_failures():
    assert LINEAR_SOLVERS.names() == ["amg", "amg_cg", "direct", "pardiso"]
    with pytest.raises(GranflowInputError, match="unknown linear solver"):
        make_linear_solver("superlu")
    with pytest.raises(GranflowInputError, match="n_velocity"):
        make_linear_solver("amg")
    with pytest.raises(GranflowInputError, match="rtol"):
        make_linear_solver("amg_cg", rtol=2.0)
    with pytest.raises(GranflowInputError, match="unknown parameter"):
        make_linear_solver("direct", tol=1e-3)
    A, b = variable_poisson(32)
    with pytest.raises(LinearSolverError):
        make_linear_solver("amg_cg", rtol=1e-12, max_iterations=2).solve(A, b)
    g = Grid(nx=4, nz=3, Lx=0.4, Lz=0.3)
    B = velocity_near_nullspace(g)
    ops = dp_model(4, 3, 0.4, 0.3).ops
    # translations, rotation and dilation have zero deviatoric strain away from the walls
    interior = np.ones(g.n_cells, dtype=bool).reshape(g.cell_shape)
    interior[[0, -1], :] = interior[:, [0, -1]] = False
    assert np.allclose((ops.ec @ B)[interior.ravel()], 0.0, atol=1e-12)
    inner_nodes = np.zeros(g.node_shape, dtype=bool)
    inner_nodes[2:-2, 1:-1] = True
    assert np.allclose((ops.en @ B)[inner_nodes.ravel()], 0.0, atol=1e-12)
    assert B.shape == (g.n_unknowns, 4)
    solver = make_linear_solver("amg", n_velocity=g.n_unknowns, max_iterations=1, raise_on_failure=False)
    model = dp_model(4, 3, 0.4, 0.3)
    asm = model.assembler
    K = asm.saddle(asm.velocity_data(np.ones(g.n_unknowns), np.ones(g.n_cells), np.ones(g.n_nodes)),
                   np.ones(g.n_cells, dtype=bool), np.ones(g.n_cells))
    rhs = np.arange(K.shape[0], dtype=float)
    x, info = solver.solve(K, rhs)
    assert info.iterations <= 1 and np.all(np.isfinite(x))
    assert solver.describe()["n_velocity"] == g.n_unknowns
