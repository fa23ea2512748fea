"""The injected bed reaches the model's homogeneous expansion (issue 13 item 1; granflow.cases.
preparation with granflow.theory.fluidisation; validation/roche/README.md).

References, independent of the solver: the root phi_e of the drag/weight balance
d^2 (1-phi)^3 rho_s g / (150 eta_f phi) = U, solved here with SciPy's brentq on the expression
written out (not the Cardano form of the code under test), and the kinematic-wave expansion time
t_s = H0 (phi0/phi_e - 1)/(U - U_mf(phi0)) of a bed released at phi0 (the fluidisation front
reaching the rising surface): the preparation must not call the bed steady before it.
"""
from __future__ import annotations

import pytest
from scipy.optimize import brentq

from granflow.cases import preparation as prep
from granflow.config import CaseConfig

D, RHO_S, ETA_F, G, PHI0 = 70e-6, 2500.0, 1.8e-5, 9.81, 0.6


def balance_root(ratio: float) -> float:
    flux = lambda phi: D**2 * (1 - phi) ** 3 * RHO_S * G / (150 * ETA_F * phi)  # noqa: E731
    return brentq(lambda phi: flux(phi) - ratio * flux(PHI0), 0.3, PHI0, xtol=1e-14)


def front_time(ratio: float, H0: float) -> float:
    u_mf = D**2 * (1 - PHI0) ** 3 * RHO_S * G / (150 * ETA_F * PHI0)
    return H0 * (PHI0 / balance_root(ratio) - 1) / ((ratio - 1) * u_mf)


def bed(ratio: float, H0: float, nz: int, max_time: float, picard: dict | None = None) -> CaseConfig:
    """A reservoir 2 cells wide, the box 1.5 H0 tall (nz cells), linear gas, DP closure;
    ``picard``: the ``numerics.picard`` section (default: none)."""
    Lz = 1.5 * H0
    dz = Lz / nz
    return CaseConfig.from_dict({
        "case": {"name": "column_collapse"},
        "setup": {"H0": H0, "L0": 2 * dz, "preparation": "injection", "U_prep_over_Umf": ratio,
                  "prep_max_time": max_time},
        "material": {"d": D, "rho_s": RHO_S, "eta_f": ETA_F, "phi_max": PHI0},
        "closure": {"name": "drucker_prager", "delta_deg": 26.74}, "gas": {"law": "linear"},
        "grid": {"nx": 4, "nz": nz, "Lx": 4 * dz, "Lz": Lz}, "time": {"stop_time": 0.003, "dt_max": 2e-3},
        **({"numerics": {"picard": picard}} if picard else {})})


def check_steady_expansion(ratio: float, H0: float, nz: int, tol: float, picard: dict | None = None) -> dict:
    t_s = front_time(ratio, H0)
    result = prep.prepare(bed(ratio, H0, nz, max_time=3 * t_s, picard=picard))
    d = result.diagnostics()
    phi_e = balance_root(ratio)
    print(f"\nU/U_mf = {ratio}: steady = {d['prep_steady']} at t = {d['prep_time_s']:.3f} s "
          f"(front {t_s:.3f} s), phi = {d['prep_phi_mean']:.5f} vs {phi_e:.5f} "
          f"({d['prep_phi_mean'] / phi_e - 1:+.2e}), drift {d['prep_height_drift_m_s']:.2e} m/s")
    assert d["prep_steady"]
    assert d["prep_phi_expected"] == pytest.approx(phi_e, abs=1e-12)
    assert d["prep_phi_mean"] == pytest.approx(phi_e, rel=tol)
    # declared only once reached: not before the front has crossed the bed
    assert d["prep_time_s"] >= 0.95 * t_s
    assert d["prep_expansion_time_s"] == pytest.approx(t_s, rel=1e-9)
    assert d["prep_height_drift_m_s"] <= d["prep_height_drift_limit_m_s"]
    return d


def test_steady_injected_bed_matches_the_homogeneous_expansion_at_1_3_u_mf():
    """1 cm bed, 8 cells over it (12 in the box), U = 1.3 U_mf: steady at 0.400 s, phi 0.56812
    against 0.57067 (-0.45 %; session 25); tolerance 1 % (issue 13). ~6 s."""
    check_steady_expansion(1.3, H0=0.01, nz=12, tol=1e-2)


ONE_SOLVE = {"max_sweeps": 1, "predictor": "extrapolated"}


def test_one_solve_per_step_expands_the_bed_at_1_1_u_mf():
    """One solve per step (docs/solver.md) carries the interior free cells from step to step
    (granflow.active_set): the bed the gas barely lifts expands to the law as the Picard loop does.
    1 cm bed, 8 cells over it, U = 1.1 U_mf; tolerance 1 % (issue 13)."""
    check_steady_expansion(1.1, H0=0.01, nz=12, tol=1e-2, picard=ONE_SOLVE)


def test_without_the_carried_free_set_one_solve_keeps_the_bed_packed(monkeypatch):
    """The control: with every dense cell active at each step's start (carried_free disabled), the
    single solve puts the gas-lifted bed in tension (p < 0) every step and it never expands."""
    import granflow.active_set

    monkeypatch.setattr(granflow.active_set, "carried_free", lambda *args: None)
    t_s = front_time(1.1, 0.01)
    d = prep.prepare(bed(1.1, 0.01, 12, max_time=0.5 * t_s, picard=ONE_SOLVE)).diagnostics()
    assert d["prep_phi_mean"] == pytest.approx(PHI0, abs=1e-6)
    assert d["prep_phi_mean"] > balance_root(1.1) * 1.01


def test_rising_bed_is_not_declared_steady():
    """Stopped at half the front time the bed is still rising at ~U - U_mf(phi0): not steady."""
    t_s = front_time(1.3, 0.01)
    result = prep.prepare(bed(1.3, 0.01, 12, max_time=0.5 * t_s))
    assert not result.steady
    assert result.height_drift > 10 * result.drift_limit


@pytest.mark.slow
@pytest.mark.parametrize("ratio", [1.1, 1.3, 1.6])
def test_steady_bed_matches_the_expansion_law_at_three_velocities(ratio):
    """2 cm bed, 20 cells over it (30 in the box): measured -0.06 %, -0.03 %, +0.01 % at 1.1, 1.3,
    1.6 U_mf (steady at 0.78, 0.77, 0.83 s; session 26, validation/roche results.json); tolerance
    1 %. ~3 s each."""
    check_steady_expansion(ratio, H0=0.02, nz=30, tol=1e-2)


def test_validation_script_quick():
    """validation/roche/run.py --quick (the small bed at 1.3 U_mf) runs and reports the table row."""
    from _scripts import load_script

    rows = load_script("validation/roche/run.py", "roche_run").main(["--quick", "--part", "expansion"])["expansion"]
    assert len(rows) == 1 and rows[0]["U_over_Umf"] == 1.3 and rows[0]["prep_steady"]
    assert rows[0]["prep_phi_mean"] == pytest.approx(balance_root(1.3), rel=1e-2)
