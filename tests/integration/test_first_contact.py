"""Issue 16, "first contact": what a new user hits in the first hour.

* item 2: every collapse example runs to rest; a run that ends while still moving says so
  (summary ``still_moving``/``warnings``, a console warning, "(still moving: not final)");
* item 8: each case prints its own headline (no "run-out 0 m" for a sheared layer), and the energy
  residual is reported absolutely with its reference (no -4e10 "relative" residual of a static bed);
* item 6: dimensionless cases print their units.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from granflow.cases import CASES
from granflow.cli import ExitCode, main
from granflow.config import load_case
from granflow.output import ordered

from _scripts import ROOT  # noqa: E402  (the repository; tests/ holds tiers)
EXAMPLES = ROOT / "examples"
TINY = ["--set", "grid.nx=16", "--set", "grid.nz=6", "--set", "output.figures=false"]


def run(capsys, example: str, out: Path, *sets: str) -> tuple[dict, str, str]:
    argv = ["run", str(EXAMPLES / example), "--out", str(out), "--quiet"]
    for item in sets:
        argv += ["--set", item]
    code = main(argv)
    stdout, stderr = capsys.readouterr()
    assert code == ExitCode.OK, stderr
    return json.loads((out / "summary.json").read_text()), stdout, stderr


# ------------------------------------------------------------------------------ item 2
def settling_examples() -> list[Path]:
    """The examples of the cases whose flow comes to rest (collapses), read from the registry."""
    out = []
    for path in sorted(EXAMPLES.glob("*.toml")):
        text = path.read_text()
        if "[case]" in text and CASES.get(load_case(path).case.name).settles:
            out.append(path)
    return out


def test_collapse_cases_are_the_settling_ones():
    names = {n for n in CASES if CASES.get(n).settles}
    assert names == {"column_collapse", "lagree_column"}
    assert len(settling_examples()) >= 5


@pytest.mark.parametrize("path", settling_examples(), ids=lambda p: p.name)
def test_every_collapse_example_runs_to_rest(path):
    """time.stop_at_rest is set and stop_time is an upper bound, not the end of the flow."""
    cfg = load_case(path)
    assert cfg.time.stop_at_rest is not None and cfg.time.stop_at_rest > 0, path.name
    assert cfg.time.max_steps is None
    assert cfg.time.stop_time >= 1.5 if cfg.case.name == "column_collapse" else cfg.time.stop_time >= 8.0


def test_a_run_cut_off_while_moving_says_so(tmp_path, capsys):
    s, out, err = run(capsys, "column_collapse_dry.toml", tmp_path / "cut", "time.stop_time=0.03",
                      *TINY[1::2])
    assert s["status"] == "completed" and s["t_rest"] is None
    assert s["still_moving"] is True
    assert s["rms_speed_final"] > s["rest_speed"]
    moving = [w for w in s["warnings"] if w.startswith("still moving")]
    assert len(moving) == 1 and "still moving at t = 0.03 s" in moving[0]
    assert "not final" in moving[0] and "time.stop_at_rest" in moving[0]
    assert "granflow: warning: still moving" in err
    assert "(still moving: not final)" in out


def test_a_layer_at_rest_is_not_flagged(tmp_path, capsys):
    """A 'column' filling the box is a layer at rest: t_rest is set from the first step on."""
    s, out, err = run(capsys, "column_collapse_dry.toml", tmp_path / "rest", "time.stop_time=0.02",
                      "setup.L0=0.375", "setup.H0=0.025", *TINY[1::2])
    assert s["t_rest"] is not None
    assert s["still_moving"] is False
    assert not [w for w in s["warnings"] if "still moving" in w]
    assert "still moving" not in out + err


# ------------------------------------------------------------------------------ item 8
def test_sheared_layer_prints_its_own_headline(tmp_path, capsys):
    s, out, _ = run(capsys, "sheared_layer.toml", tmp_path / "sh", "time.stop_time=5e-4",
                    "output.figures=false")
    d = s["case_diagnostics"]
    assert "run-out" not in out
    assert f"{d['max_error_rel']:.2e}" in out and f"{d['phi_eq']:.5g}" in out
    assert s["still_moving"] is False and not [w for w in s["warnings"] if "still moving" in w]


def test_static_layer_headline_and_energy_without_a_reference(tmp_path, capsys):
    """A layer at rest releases no energy: no relative residual (it used to be ~1e10), the
    absolute residual is reported and is tiny compared with the energy present."""
    s, out, _ = run(capsys, "static_layer.toml", tmp_path / "st", "time.stop_time=0.005",
                    "output.figures=false")
    assert "run-out" not in out and "pressure against lithostatic" in out
    e = s["energy_residual"]
    assert e["absolute"] == pytest.approx(s["energy"]["residual"], rel=0, abs=0)
    assert e["reference"] is None and e["relative"] is None and s["energy_residual_rel"] is None
    assert abs(e["absolute"]) <= 1e-6 * e["energy_present"]


def test_energy_reference_is_the_largest_source():
    """energy_residual against budgets built by hand."""
    from types import SimpleNamespace

    from granflow.cases.runner import energy_residual

    def budget(released, released_gas, injected, residual=-0.5):
        return SimpleNamespace(released=released, released_gas=released_gas, injected=injected,
                               residual=residual, e_p0=-10.0, e_k0=0.0, e_10=2.0)

    e = energy_residual(budget(2.0, 0.1, 0.0))
    assert e["reference"] == "released potential energy" and e["relative"] == pytest.approx(-0.25)
    e = energy_residual(budget(1e-14, 1.0, 0.0))   # a draining bed at rest: the gas energy
    assert e["reference"] == "released gas energy" and e["relative"] == pytest.approx(-0.5)
    e = energy_residual(budget(1e-14, -1e-15, 0.0))  # nothing released
    assert e["reference"] is None and e["relative"] is None and e["absolute"] == -0.5


def test_completion_line_of_each_case():
    """The headline functions read the summary's own values (synthetic summaries)."""
    from granflow.cli.run import completion_line

    base = {"t_final": 0.5, "steps": 10, "wall_s": 1.0, "runout_m": 0.123,
            "front_position": {"final_m": 0.223}, "still_moving": False}
    line = completion_line(CASES.get("column_collapse"), base)
    assert "run-out 0.123 m (front 0.223 m)" in line and "t = 0.5 s" in line
    lag = dict(base, runout_m=1.5, case_diagnostics={"runout": {"x_f": 2.2, "relative": 2.1, "lambda1": 1.48}})
    line = completion_line(CASES.get("lagree_column"), lag)
    assert "run-out 1.5 H0" in line and "lambda1 = 1.48" in line and "sqrt(H0/g)" in line
    assert " m" not in line.replace(" m)", "")  # no metres anywhere
    incl = dict(base, case_diagnostics={"u_surface_m_s": 0.5, "u_surface_bagnold_m_s": 0.48,
                                        "u_surface_rel_error": 0.5 / 0.48 - 1, "profile_max_error_rel": 0.03,
                                        "steady": True})
    line = completion_line(CASES.get("inclined_layer"), incl)
    assert "Bagnold 0.48 m/s (+4.17 %)" in line and "run-out" not in line
    defl = dict(base, case_diagnostics={"half_life_s": 0.0101, "series_half_life_s": 0.01,
                                        "half_life_rel_error": 0.01, "max_error_rel": 4e-3})
    line = completion_line(CASES.get("defluidisation_column"), defl)
    assert "half-life 0.0101 s" in line and "(+1 %)" in line and "run-out" not in line
    moving = dict(base, still_moving=True)
    assert completion_line(CASES.get("column_collapse"), moving).endswith("(still moving: not final)")
    unconverged = dict(base, picard={"not_converged_steps": 5, "max_sweeps": 10})
    assert completion_line(CASES.get("column_collapse"), unconverged).endswith("Picard not converged in 5 of 10 steps")
    one_solve = dict(base, picard={"not_converged_steps": 5, "max_sweeps": 1})  # by choice: no "not converged"
    line = completion_line(CASES.get("column_collapse"), one_solve)
    assert line.endswith("; one solve per step (numerics.picard.max_sweeps = 1)") and "not converged" not in line
    assert math.isfinite(base["runout_m"])


# ------------------------------------------------------------------------------ item 6
def test_dimensionless_case_prints_and_plots_its_own_units(tmp_path, capsys, monkeypatch):
    """lagree_column: the console, output.nc, summary.json and both figures are in H0,
    sqrt(H0/g), sqrt(g H0); front.png names the closure actually used (incompressible), not the
    [closure] default (drucker_prager) that the case ignores."""
    import netCDF4

    saved = _capture_figures(monkeypatch)
    out = tmp_path / "lag"
    s, stdout, stderr = run(capsys, "lagree_column.toml", out, "grid.nx=16", "grid.nz=16",
                            "time.stop_time=0.2")
    line = stdout.strip().splitlines()[-1]
    assert "t = 0.2 sqrt(H0/g)" in line and "H0" in line
    import re

    head = re.sub(r"\([\d.]+ s wall\)", "", line.split("; output in")[0])  # wall time is in s
    assert not re.search(r"\d (m|s|m/s)\b", head), head
    assert "sqrt(g H0)" in stderr  # the still-moving warning, in the case's speed unit
    assert s["units"]["runout_m"] == "H0" and s["units"]["t_final"] == "sqrt(H0/g)"
    with netCDF4.Dataset(out / "output.nc") as nc:
        assert nc["x"].units == "H0" and nc["time"].units == "sqrt(H0/g)"
        assert "standard_name" not in nc["time"].ncattrs() and "standard_name" not in nc["z"].ncattrs()
        assert nc["u"].units == "sqrt(g H0)" and nc["kinetic_energy"].units == "rho g H0^3"
        assert nc.getncattr("closure") == "incompressible"
    front = saved["front.png"].axes
    assert front[0].get_xlabel() == "t [sqrt(H0/g)]" and front[0].get_ylabel() == "front position [H0]"
    assert front[1].get_ylabel() == "kinetic energy [rho g H0^3]"
    assert "incompressible" in front[0].get_title() and "drucker_prager" not in front[0].get_title()
    snap = saved["snapshots.png"].axes[0]
    assert snap.get_xlabel() == "x [H0]" and "sqrt(H0/g)" in snap.get_title()
    assert s["figures"]["files"] == ["snapshots.png", "front.png"]


def test_si_case_keeps_si_units(tmp_path, capsys):
    import netCDF4

    s, stdout, _ = run(capsys, "column_collapse_dry.toml", tmp_path / "si", "time.stop_time=0.01",
                       *TINY[1::2])
    with netCDF4.Dataset(tmp_path / "si" / "output.nc") as nc:
        assert nc["x"].units == "m" and nc["time"].units == "s" and nc["p"].units == "Pa"
        # CF (issue 16 item 11): a time axis with units s and axis T, standard names
        assert nc["time"].axis == "T" and nc["time"].standard_name == "time"
        assert nc["z"].standard_name == "height" and nc["z"].positive == "up"
        assert nc.getncattr("closure") == "drucker_prager"
    assert s["units"]["runout_m"] == "m" and "note" not in s["units"]
    assert " m (front " in stdout


# ------------------------------------------------------------------------------ item 4
def _capture_figures(monkeypatch) -> dict:
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    saved = {}
    original = Figure.savefig

    def keep(self, path, *args, **kwargs):
        saved[Path(path).name] = self
        return original(self, path, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", keep)
    return saved


def _speed_contours(fig):
    from granflow import plotting

    return [(ax, c) for ax in fig.axes for c in ax.collections if c.get_gid() == plotting.SPEED_CONTOUR_GID]


def test_snapshot_speed_contours_are_grain_only_labelled_and_above_noise(tmp_path, capsys, monkeypatch):
    """A collapse in motion: speed contours are labelled, every level is above the run's rest
    speed, and no contour leaves the grains (c > 0, the material fraction read from output.nc)."""
    import netCDF4

    saved = _capture_figures(monkeypatch)
    out = tmp_path / "cc"
    s, _, _ = run(capsys, "column_collapse_dry.toml", out, "time.stop_time=0.1", "grid.nx=32",
                  "grid.nz=12")
    fig = saved["snapshots.png"]
    contours = _speed_contours(fig)
    assert contours, "the moving column has speed contours"
    with netCDF4.Dataset(out / "output.nc") as nc:
        x, z = np.asarray(nc["x"][:]), np.asarray(nc["z"][:])
        c = ordered(nc["c"]).astype(float)  # (time, x, z)
        rest = float(nc.getncattr("rest_speed"))
    dx, dz = x[1] - x[0], z[1] - z[0]
    for ax, cs in contours:
        assert min(cs.levels) > rest
        assert len(ax.texts) >= 1  # clabel: the levels are labelled
        record = int(np.argmin([abs(float(ax.get_title().split("t = ")[1].split()[0]) - t)
                                for t in s["front_position"]["t_s"]]))
        grains = c[record] > 0.0
        top = np.array([z[np.flatnonzero(col)].max() if col.any() else -np.inf for col in grains])
        for path in cs.get_paths():
            for xv, zv in path.vertices:
                i = int(np.clip(np.floor(xv / dx), 0, x.size - 1))
                near = top[max(i - 1, 0): i + 2]
                assert zv <= near.max() + dz / 2 + 1e-12, (xv, zv)
    assert "grain speed" in fig.get_suptitle() and "front" in fig.get_suptitle()


def test_static_layer_snapshot_draws_no_noise_contours(tmp_path, capsys, monkeypatch):
    saved = _capture_figures(monkeypatch)
    run(capsys, "static_layer.toml", tmp_path / "st", "time.stop_time=0.01")
    from matplotlib.contour import ContourSet

    assert "snapshots.png" in saved
    drawn = [c for ax in saved["snapshots.png"].axes for c in ax.collections if isinstance(c, ContourSet)]
    assert drawn == []  # no contour of the 1e-12 m/s noise of a layer at rest


# ------------------------------------------------------------------------------ item 7
def test_progress_says_compiling_first_and_times_later_steps_without_it(tmp_path):
    """The first step compiles the kernels: its progress has no rate or ETA (it printed
    "ETA 6:23:47"); the line says "compiling kernels (once)"; later steps get a finite ETA."""
    import io

    from granflow.cases.runner import CaseRun
    from granflow.cli.run import ProgressPrinter

    cfg = load_case(EXAMPLES / "column_collapse_dry.toml",
                    ["grid.nx=16", "grid.nz=6", "time.stop_time=0.01", "output.figures=false"])
    from granflow.cases.step_clock import MIN_TIMED_STEPS

    seen = []
    run_ = CaseRun(cfg, tmp_path / "p", progress=seen.append)
    run_.run()
    assert seen[0].warming_up and not math.isfinite(seen[0].eta_s) and seen[0].steps_per_s == 0.0
    assert all(p.warming_up for p in seen[:MIN_TIMED_STEPS])
    assert not seen[-1].warming_up and math.isfinite(seen[-1].eta_s) and seen[-1].steps_per_s > 0
    stream = io.StringIO()
    printer = ProgressPrinter(stream, log_interval=0.0, tty=False)
    printer.starting(0.0, 0.01)
    printer(seen[0])
    lines = stream.getvalue().splitlines()
    assert all("compiling kernels (once)" in ln and "ETA" not in ln for ln in lines)
    assert "ETA 0:00:0" in ProgressPrinter.line(seen[-1]) or "ETA 0:00:00" in ProgressPrinter.line(seen[-1])


def test_eta_waits_for_every_compiling_step():
    """The flagship's measured step times (30 x 10 cells): steps 1 and 2 compile (0.8 s each),
    then 14 ms. Timing from step 2 on gave ETA 0:18:00 for 10 s of work; every ETA shown is now
    within 20 % of the true remaining wall time, and the warm-up ends after a few steps."""
    from granflow.cases.step_clock import StepClock

    durations = [0.8, 0.8] + [0.014] * 200
    dt, stop = 1e-3, 1e-3 * len(durations)
    clock, now, shown = StepClock(), 0.0, []
    for n, d in enumerate(durations, start=1):
        now += d
        rate = clock.tick(n * dt, now, n, stop)
        if not rate.warming_up:
            shown.append((rate.eta_s, sum(durations[n:])))
    assert len(shown) >= len(durations) - 6
    for eta, true in shown:
        assert eta == pytest.approx(true, rel=0.2, abs=0.05)
    late = StepClock()  # a slow step late in the run (a dt halving, an output) is not a compilation
    now = 0.0
    for n, d in enumerate([0.8] + [0.014] * 20 + [0.5] + [0.014] * 5, start=1):
        now += d
        rate = late.tick(n * dt, now, n, 1.0)
    assert rate.steps_per_s < 1.0 / 0.014  # the slow step is still in the average


def test_picard_non_convergence_is_reported(tmp_path, capsys):
    # the loop's warning (one solve per step, max_sweeps = 1, does not iterate by choice)
    s, out, err = run(capsys, "column_collapse_fluidised.toml", tmp_path / "fl", "time.stop_time=0.05",
                      "numerics.picard.max_sweeps=10", *TINY[1::2])
    n = s["picard"]["not_converged_steps"]
    assert s["picard"]["not_converged_fraction"] == pytest.approx(n / s["steps"])
    picard = [w for w in s["warnings"] if w.startswith("Picard")]
    assert len(picard) == (1 if n else 0)
    if n:
        assert f"{n} of {s['steps']} steps" in picard[0] and f"{n} of {s['steps']} steps" in out
    from granflow.cli.run import completion_line

    line = completion_line(CASES.get("column_collapse"), dict(
        t_final=1.0, steps=728, wall_s=1.0, runout_m=0.2, front_position={"final_m": 0.3},
        picard={"not_converged_steps": 136}))
    assert line.endswith("; Picard not converged in 136 of 728 steps")


# ------------------------------------------------------------------------------ item 11
def test_derive_prints_a_simplified_f_equal_to_the_derivation(capsys):
    import re

    import sympy as sp

    from granflow.rheology import derive_dilatancy
    from granflow.rheology.derive import I, I_eq

    expr = "0.38 + 0.27*I/(I + 0.3)"
    assert main(["derive", expr]) == ExitCode.OK
    out = capsys.readouterr().out
    assert not re.search(r"\d{13,}", out)  # it printed log(443426488243037769948249630619149892803/...)
    assert "LaTeX" not in out
    printed = next(ln for ln in out.splitlines() if ln.strip().startswith("f = ")).split("=", 1)[1]
    f_printed = sp.sympify(printed, locals={"I": I, "I_eq": I_eq})
    exact = derive_dilatancy(expr).f
    for i_val, ieq_val in ((0.01, 0.2), (0.7, 0.05), (2.0, 1.3)):
        point = {I: i_val, I_eq: ieq_val}
        assert float(f_printed.subs(point)) == pytest.approx(float(exact.subs(point)), rel=1e-12)
    assert main(["derive", expr, "--latex"]) == ExitCode.OK
    assert "LaTeX: " in capsys.readouterr().out


def test_ctrl_c_during_start_up_exits_130(monkeypatch, capsys):
    import granflow.cli as cli

    def interrupted():
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "build_parser", interrupted)
    assert main(["run", "x.toml"]) == 130
    assert "interrupted" in capsys.readouterr().err


def test_vtk_first_edge_is_exactly_zero():
    from granflow.output.vtk import cell_edges

    dx = 0.4 / 40
    centres = (np.arange(40) + 0.5) * dx
    edges = cell_edges(centres)
    assert edges[0] == 0.0 and edges[-1] == pytest.approx(0.4, rel=1e-12)
    np.testing.assert_allclose(np.diff(edges), dx, rtol=1e-9)


def test_readme_names_every_figure_the_flagship_writes():
    """The figures run_figures writes for the flagship (probes.png when output.probes_x is set)
    are the ones the README's opening paragraph lists, and their number is spelled right."""
    cfg = load_case(EXAMPLES / "column_collapse_fluidised.toml")
    expected = ["snapshots.png", "front.png"] + (["probes.png"] if cfg.output.probes_x else [])
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    opening = text.split("## ")[0]
    for name in expected:
        assert f"`{name}`" in opening, name
    words = {2: "two", 3: "three"}
    assert f"{words[len(expected)]} figures" in opening


# ------------------------------------------------------------------------------ item 9
def _lines_by_label(ax) -> dict:
    return {ln.get_label(): ln for ln in ax.get_lines()}


def test_defluidisation_figure_is_p_f_against_the_series(tmp_path, capsys, monkeypatch):
    saved = _capture_figures(monkeypatch)
    s, _, _ = run(capsys, "defluidisation_column.toml", tmp_path / "d", "grid.nz=6",
                  "time.stop_time=0.05", "time.dt_max=1e-3")
    assert "basal_pressure.png" in s["figures"]["files"]
    top, bottom = saved["basal_pressure.png"].axes
    rec = s["case_diagnostics"]["basal_record"]
    lines = _lines_by_label(top)
    series = next(ln for k, ln in lines.items() if k.startswith("Fourier"))
    data = next(ln for k, ln in lines.items() if k.startswith("granflow"))
    np.testing.assert_allclose(series.get_ydata(), rec["series_Pa"], rtol=1e-12)
    np.testing.assert_allclose(data.get_ydata(), rec["p_f_Pa"], rtol=1e-12)
    amp = s["case_diagnostics"]["p_f0_base_Pa"]
    err = (np.asarray(rec["p_f_Pa"]) - np.asarray(rec["series_Pa"])) / amp
    np.testing.assert_allclose(bottom.get_lines()[0].get_ydata(), err, rtol=1e-9, atol=1e-15)
    assert top.get_ylabel() == "basal pore pressure p_f [Pa]" and bottom.get_xlabel() == "t [s]"
    lo, hi = top.get_ylim()
    assert lo <= min(rec["p_f_Pa"]) and hi >= max(rec["p_f_Pa"])


def test_inclined_figure_is_u_of_z_against_bagnold(tmp_path, capsys, monkeypatch):
    import netCDF4

    saved = _capture_figures(monkeypatch)
    out = tmp_path / "i"
    s, _, _ = run(capsys, "inclined_layer.toml", out, "time.stop_time=1.0")
    d = s["case_diagnostics"]
    profile, surface = saved["profile.png"].axes
    lines = _lines_by_label(profile)
    bagnold = lines["Bagnold"]
    assert max(bagnold.get_xdata()) == pytest.approx(d["u_surface_bagnold_m_s"], rel=1e-12)
    assert max(bagnold.get_ydata()) == pytest.approx(d["h_m"], rel=1e-12)
    with netCDF4.Dataset(out / "output.nc") as nc:
        u = ordered(nc["u"])[-1].astype(float)  # (x, z)
        grains = ordered(nc["c"])[-1] > 0.0  # the material (indicator surface, the default)
    import warnings

    with warnings.catch_warnings():  # the ambient rows have no grain cell: NaN
        warnings.simplefilter("ignore", RuntimeWarning)
        expected = np.nanmean(np.where(grains, u, np.nan), axis=0)
    drawn = next(ln for k, ln in lines.items() if k.startswith("granflow")).get_xdata()
    np.testing.assert_allclose(np.asarray(drawn, dtype=float), expected, rtol=1e-12, equal_nan=True)
    assert profile.get_xlabel() == "u [m s-1]" and profile.get_ylabel() == "z [m]"
    us = _lines_by_label(surface)["surface speed u_s"]
    np.testing.assert_allclose(us.get_ydata(), d["u_surface_record"]["u_m_s"], rtol=1e-12)
    snap = saved["snapshots.png"].axes[0]
    assert snap.get_aspect() == "auto"  # a 4 x 22 box drawn to scale was a sliver


def test_sheared_layer_figure_and_static_front_figure(tmp_path, capsys, monkeypatch):
    saved = _capture_figures(monkeypatch)
    s, _, _ = run(capsys, "sheared_layer.toml", tmp_path / "s", "time.stop_time=5e-4")
    rec = s["case_diagnostics"]["phi_record"]
    lines = _lines_by_label(saved["relaxation.png"].axes[0])
    np.testing.assert_allclose(lines["granflow"].get_ydata(), rec["phi"], rtol=1e-12)
    np.testing.assert_allclose(lines[s["case_diagnostics"]["reference"]].get_ydata(), rec["reference"], rtol=1e-12)
    assert "front.png" not in saved  # a fixed front and no motion: nothing to draw
    saved.clear()
    s, _, _ = run(capsys, "static_layer.toml", tmp_path / "st", "time.stop_time=0.01")
    assert "front.png" not in saved and s["figures"]["files"] == ["snapshots.png", "pressure.png"]
    prof = s["case_diagnostics"]["pressure_profile"]
    left, right = saved["pressure.png"].axes
    lines = _lines_by_label(left)
    np.testing.assert_allclose(lines["granflow (mean over x)"].get_ydata(), prof["z_m"], rtol=1e-12)
    np.testing.assert_allclose(lines["granflow (mean over x)"].get_xdata(), prof["p_Pa"], rtol=1e-12)
    ref = next(ln for k, ln in lines.items() if k.startswith("lithostatic"))
    np.testing.assert_allclose(ref.get_xdata(), prof["reference_Pa"], rtol=1e-12)
    full = np.asarray(prof["full"])
    assert full.size == 7 and full.all()  # H = 0.07 m on 1 cm cells: 7 whole rows, none above
    np.testing.assert_allclose(np.asarray(prof["p_Pa"])[full], np.asarray(prof["reference_Pa"])[full],
                               rtol=1e-9)
    assert left.get_xlabel() == "granular pressure p [Pa]" and left.get_ylabel() == "z [m]"


def test_dispersion_plot_labels_fit_in_the_figure(tmp_path, monkeypatch):
    saved = _capture_figures(monkeypatch)
    assert main(["stability", "dispersion", "roux_radjai", "--I", "1e-2", "--p", "1000",
                 "--plot", str(tmp_path / "rr.png")]) == ExitCode.OK
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig = saved["rr.png"]
    renderer = FigureCanvasAgg(fig).get_renderer()
    box = fig.bbox
    for ax in fig.axes:
        for label in (ax.xaxis.label, ax.yaxis.label, ax.title):
            if label.get_text():
                ext = label.get_window_extent(renderer)
                assert ext.x0 >= box.x0 - 1 and ext.x1 <= box.x1 + 1 and ext.y0 >= box.y0 - 1 and ext.y1 <= box.y1 + 1, label.get_text()
