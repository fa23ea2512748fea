"""Energy budget of the dry column collapse under Δt and Δx refinement (issue 3 items 7 and 9f;
MODEL.md §5; validation/energy/README.md), on tiny grids.

Independent references: the discrete energy identity itself (the budget's residual is computed
from the energies and the physical dissipation; the numerical parts are accumulated separately
from the step reports, so their equality is a check of both), exact mass conservation of the
conservative phi transport, the bounds [0, phi_max] (paper Theorem th4), and the first-order
truncation error of backward Euler (``sum rho |u^{n+1} - u^n|^2 / 2 = O(dt)`` per unit time
where the velocity is smooth in time). The runs go through validation/energy/run.py, so that
script is smoke-tested too.

The grids are the validation's Δx series (0.4 x 0.16 m, square cells, the 10 x 10 cm column
on cell faces): 20 x 8 and 40 x 16 cells, to t = 0.15 s (the front is still advancing).

Schemes (run.py ``SCHEME_NUMERICS``): "upwind" is scheme v1 pinned (upwind momentum advection and
the threshold surface); the tests on it check properties of v1 (its exact identity, its
backward-Euler events, its advection loss at the sheared surface) and serve as the reference that
v2 must beat. "v2" is the default numerics since 180fbc3 (consistent transport, indicator
surface): :func:`test_v2_default_budget`.
"""
from __future__ import annotations


import pytest
from _scripts import load_script

T_END = 0.15
"""[s]: the bulk still moves (it stops at ~0.45 s)."""
LZ = 0.16
COARSE, FINE = (20, 8), (40, 16)
DT_COARSE = (2.0e-3, 1.0e-3)
"""dt_max [s] of the Δt pair at 20 x 8 (the CFL never shortens them here: measured)."""
DT_SLOW = (2.0e-3, 1.0e-3, 5.0e-4, 2.5e-4)
"""dt_max [s] of the slow Δt series on the example grid 40 x 15 to 0.3 s (README table)."""
IDENTITY_TOL = 1e-8
"""|sum of the numerical parts - residual| / released energy (measured <= 1e-15)."""
MASS_TOL = 1e-12
"""|transport mass error| / initial mass (measured <= 3e-16)."""


def _load():
    return load_script("validation/energy/run.py", "validation_energy_run")


@pytest.fixture(scope="module")
def energy():
    return _load()


@pytest.fixture(scope="module")
def dt_series(energy):
    """20 x 8, dt_max = 2 and 1 ms, scheme v1 (upwind + threshold surface), to T_END (~2 s)."""
    return [energy.run_one("dry", *COARSE, LZ, dt, "upwind", T_END) for dt in DT_COARSE]


@pytest.fixture(scope="module")
def fine(energy):
    """40 x 16, dt_max = 1 ms (Δt ∝ Δx with the 2 ms of 20 x 8), scheme v1, to T_END (~4 s)."""
    return energy.run_one("dry", *FINE, LZ, 1.0e-3, "upwind", T_END)


def _be_rest(r) -> float:
    """Backward-Euler energy outside the one-step events (run.py, RegionAudit) / released."""
    return r["parts_rel"]["backward_euler"] - r["be_events_rel"]


def _runs(dt_series, fine):
    return [*dt_series, fine]


def test_energy_identity_is_exact(dt_series, fine):
    """err = E_k + E_p - (E_k + E_p)(0) + int D dt equals the sum of the numerical parts."""
    for r in _runs(dt_series, fine):
        print(f"\n{r['nx']}x{r['nz']} dt {r['dt_max']:g}: residual {r['residual_rel']:+.4f}, "
              f"identity {r['identity_rel']:.1e}, mechanical {r['identity_mech_rel']:.1e}, "
              f"audit {r['audit_mismatch_rel']:.1e}")
        assert r["released_J_m"] > 0
        assert abs(r["identity_rel"]) <= IDENTITY_TOL
        assert abs(r["identity_mech_rel"]) <= IDENTITY_TOL
        # the per-region recomputation of the advection energy matches the step reports
        assert r["audit_mismatch_rel"] <= IDENTITY_TOL
        # the residual is numerical DISSIPATION, a fraction of the released energy
        assert -1.0 < r["residual_rel"] < 0.0


def test_mass_and_bounds(dt_series, fine):
    """Transport mass error (clipped mass counted) to round-off; phi in [0, phi_max]."""
    for r in _runs(dt_series, fine):
        print(f"\n{r['nx']}x{r['nz']} dt {r['dt_max']:g}: mass err {r['mass_err']:.1e}, clipped "
              f"{r['clipped_rel']:.1e}, limited {r['limited_rel']:.1e}, phi in [{r['phi_min']}, "
              f"{r['phi_max']}], max before clip {r['phi_max_before_clip']:.6f}")
        assert abs(r["mass_err"]) <= MASS_TOL
        assert r["phi_min"] >= 0.0 and r["phi_max"] <= r["phi_max_allowed"]
        assert r["added_rel"] == 0.0
        assert r["rejected"] == 0



@pytest.fixture(scope="module")
def fluidised(energy):
    """The fluidised flagship (phi0 = 0.58, b0 = 0.9, linear gas law) at 20 x 8, 2 ms, scheme v1
    (~1 s)."""
    return energy.run_one("fluidised", *COARSE, LZ, 2.0e-3, "upwind", T_END)


def test_energy_identity_with_gas(fluidised):
    """The identity with the gas energy, Darcy dissipation and the four gas terms
    (measured identity 1e-14: the gas energy density e(p_f) ~ p_f^2/(2 p_atm) is a difference of
    terms ~p_f, so it carries a larger round-off than the dry budget). Scheme v1 here; the v2
    counterpart is in :func:`test_v2_default_budget`."""
    r = fluidised
    print(f"\nfluidised 20x8: residual {r['residual_rel']:+.4f}, identity {r['identity_rel']:.1e}, "
          f"gas part {r['gas_rel']:+.2e}, mass err {r['mass_err']:.1e}")
    assert abs(r["identity_rel"]) <= IDENTITY_TOL
    assert abs(r["identity_mech_rel"]) <= IDENTITY_TOL
    assert abs(r["mass_err"]) <= MASS_TOL
    assert r["phi_min"] >= 0.0 and r["phi_max"] <= r["phi_max_allowed"]
    assert -1.0 < r["residual_rel"] < 0.0


def test_backward_euler_is_dominated_by_one_step_velocity_jumps(dt_series):
    """At fixed dx the backward-Euler energy does NOT shrink like dt: most of it is spent in a few
    isolated steps where the velocity jumps by O(1) (cells turning dense, p >= 0 active-set
    switches, Picard stopped at its sweep cap), whatever dt (README, "backward Euler").

    Measured (20 x 8, t = 0.15 s, dt = 2, 1 ms): BE = -5.42, -4.79 % of the released energy
    (first order would give -2.71 % at 1 ms); events -4.76, -4.28 % (88, 89 %); residual -21.3,
    -20.0 %. A scheme that removes these jumps should break the last assertion: then assert first
    order instead.
    """
    be = [r["parts_rel"]["backward_euler"] for r in dt_series]
    for r in dt_series:
        print(f"\n20x8 dt {r['dt_max']:g}: residual {r['residual_rel']:+.4f}, BE "
              f"{r['parts_rel']['backward_euler']:+.5f}, events {r['be_events_rel']:+.5f} "
              f"({r['be_events']} steps), gravity/transport {r['parts_rel']['gravity_transport']:+.1e}")
        assert r["be_events_rel"] / r["parts_rel"]["backward_euler"] >= 0.7  # measured >= 0.88
        assert abs(r["parts_rel"]["gravity_transport"]) <= 5e-3  # measured <= 4.6e-4
    assert all(r["dt_largest"] == pytest.approx(r["dt_max"]) and r["frac_shortened"] == 0.0
               for r in dt_series)  # the dt used is the dt asked for
    assert all(b < 0 for b in be)
    assert abs(be[-1]) >= 0.7 * abs(be[0])  # measured 0.88; first order: 0.5


def test_shear_sharpens_under_dx_refinement(dt_series, fine):
    """Why the advection residual does not shrink like dx: the dense shear rate grows faster than
    1/dx (no length scale in the rate-independent Drucker-Prager flow, and p -> 0 near the
    surface), so the upwind dissipation ~ dx |grad u|^2 stays O(1) (README, "advection").

    Measured at t = 0.15 s: largest |du/dz| between dense x-faces 3.7 (20 x 8) and 12.4 1/s
    (40 x 16); momentum advection + inertia transport -15.8 and -17.9 % of the released energy,
    residual -21.3 and -22.8 %.
    """
    coarse = dt_series[0]
    for r in (coarse, fine):
        p = r["parts_rel"]
        print(f"\n{r['nx']}x{r['nz']}: residual {r['residual_rel']:+.4f}, advection + inertia "
              f"{p['advection'] + p['inertia_transport']:+.4f}, max dense shear "
              f"{r['probe']['shear_domain']:.1f} 1/s")
        # the momentum advection / inertia-transport pair carries most of the residual
        assert abs(p["advection"] + p["inertia_transport"]) >= 0.5 * abs(r["residual_rel"])  # 0.74, 0.78
    assert fine["probe"]["shear_domain"] >= 2.5 * coarse["probe"]["shear_domain"]  # measured 3.4


@pytest.mark.slow
def test_dt_series_on_the_example_grid(energy):
    """The README's Δt series (40 x 15, dt_max = 2, 1, 0.5, 0.25 ms, upwind, to 0.3 s; ~1 min).

    Measured (validation/energy/run.py): residual -24.40, -24.44, -24.59, -24.56 % (flat); BE
    -4.80, -4.54, -4.62, -4.57 %; BE outside the one-step events -1.09, -0.58, -0.40, -0.25 %
    (fitted order 0.70); identity <= 1.1e-15; mass error <= 1.4e-16.
    """
    rows = [energy.run_one("dry", 40, 15, 0.15, dt, "upwind", 0.3) for dt in DT_SLOW]
    for r in rows:
        print(f"\n40x15 dt {r['dt_max']:g}: residual {r['residual_rel']:+.4f}, BE "
              f"{r['parts_rel']['backward_euler']:+.5f}, rest {_be_rest(r):+.5f}, identity {r['identity_rel']:.1e}")
        assert abs(r["identity_rel"]) <= IDENTITY_TOL
        assert abs(r["mass_err"]) <= MASS_TOL
        assert r["phi_min"] >= 0.0 and r["phi_max"] <= r["phi_max_allowed"]
    res = [r["residual_rel"] for r in rows]
    assert max(res) - min(res) <= 0.05 * abs(res[0])  # measured 0.8 % of it: flat in dt
    be = [abs(r["parts_rel"]["backward_euler"]) for r in rows]
    assert be[-1] >= 0.5 * be[0]  # measured 0.95; first order: 0.125
    rest = [abs(_be_rest(r)) for r in rows]
    assert energy.slope([r["dt_mean"] for r in rows], rest) >= 0.4  # measured 0.70


RESIDUAL_GOAL = 0.05
"""Issue 12: |energy residual| <= 5 % of the released energy under the default scheme."""


@pytest.fixture(scope="module")
def v2(energy):
    """The default numerics (scheme v2: consistent momentum transport, indicator surface): dry
    and fluidised at 20 x 8 (2 ms) and 40 x 16 (1 ms), to T_END (~7 s together)."""
    return {case: [energy.run_one(case, *COARSE, LZ, DT_COARSE[0], "v2", T_END),
                   energy.run_one(case, *FINE, LZ, 1.0e-3, "v2", T_END)]
            for case in ("dry", "fluidised")}


def test_v2_default_budget(v2, dt_series, fluidised):
    """Scheme v2 (the default) with the default step (since session 25: one linear solve per step,
    extrapolated first iterate, cfl 0.4): mass and momentum moved by the same fluxes, so the
    inertia-transport term (mass used in the solve vs mass after the transport) is at the
    linearisation's error (measured <= 1.6e-3; <= 8e-5 with the converged loop); the identity
    (with the gas terms: the gas energy at the material packing phi/c) stays exact (measured <=
    7.7e-15); the audit's recomputation of the advection energy (fluxes of the material transport
    with u^{n+1}) matches the step reports to the distance between the first iterate, whose fluxes
    the step used, and u^{n+1} (measured 1.9e-4 / 1.2e-4 dry, 8.2e-4 / 9.6e-4 fluidised; <= 9e-5
    with the converged loop, whose tolerance is 1e-3; bound 3e-3); the residual is well below
    scheme v1's on the same grid (measured 20 x 8: -8.8 % vs -24.7 % dry, -6.0 % vs -23.9 %
    fluidised), shrinks under refinement (measured dry -8.8 % -> -3.6 %, fluidised -6.0 % ->
    -2.8 %) and is within issue 12's 5 % at 40 x 16. (Session-25 measurements,
    validation/energy/README.md.)"""
    for case, runs in v2.items():
        for r in runs:
            print(f"\n{case} {r['nx']}x{r['nz']}: residual {r['residual_rel']:+.4f}, identity "
                  f"{r['identity_rel']:.1e}, parts { {k: round(v, 5) for k, v in r['parts_rel'].items() if v} }, "
                  f"audit {r['audit_mismatch_rel']:.1e}")
            assert r["numerics"]["advection"] == "consistent" and r["numerics"]["surface"] == "indicator"
            assert r["released_J_m"] > 0
            assert abs(r["identity_rel"]) <= IDENTITY_TOL
            assert abs(r["identity_mech_rel"]) <= IDENTITY_TOL
            assert abs(r["mass_err"]) <= MASS_TOL
            assert r["phi_min"] >= 0.0 and r["phi_max"] <= r["phi_max_allowed"]
            assert abs(r["parts_rel"]["inertia_transport"]) <= 5e-3
            assert r["audit_mismatch_rel"] <= 3e-3
            assert -1.0 < r["residual_rel"] < 0.0
        coarse, fine = runs
        assert abs(fine["residual_rel"]) < abs(coarse["residual_rel"])
        assert abs(fine["residual_rel"]) <= RESIDUAL_GOAL
    assert abs(v2["dry"][0]["residual_rel"]) < 0.5 * abs(dt_series[0]["residual_rel"])
    assert abs(v2["fluidised"][0]["residual_rel"]) < 0.5 * abs(fluidised["residual_rel"])
