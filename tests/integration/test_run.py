"""``granflow run``: output files, summary, progress, restart bit-identity, failures, Ctrl-C.

All runs use the shipped example on a 16 x 6 grid (dt = dt_max = 1 ms, 20-60 steps, < 1 s each).
Independent checks: the front and run-out recomputed here from the NetCDF phi (deposit thickness
sum(phi dz)/phi_max, NUMERICS.md §10); the initial mass phi0 H0 L0; exact (byte) equality for the
restart; attribute presence for self-description.
"""
from __future__ import annotations

import json
import signal
from pathlib import Path

import netCDF4
import numpy as np
import pytest
import xarray as xr

import granflow.output  # noqa: F401  (ds.granflow accessor)
from granflow.cases import CASES
from granflow.cases import column_collapse as cc
from granflow.cli import ExitCode, main
from granflow.cli.run import RunExit
from granflow.output import load_checkpoint
from granflow.simulation import IterationInterval

from _scripts import ROOT  # noqa: E402  (the repository; tests/ holds tiers)
EXAMPLE = ROOT / "examples" / "column_collapse_dry.toml"
TINY = ["--set", "grid.nx=16", "--set", "grid.nz=6", "--set", "output.interval=0.01", "--quiet"]
REQUIRED_SUMMARY_KEYS = {"runout_m", "front_position", "final_height_at_wall", "t_rest", "mass_rel_error",
                         "phi_min", "phi_max", "clipped_mass", "energy_residual_rel", "steps", "wall_s",
                         "closure", "resolution"}
PHI_MAX = 0.6


def run_cli(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def tiny(capsys, out: Path, stop_time: float = 0.05, *extra):
    return run_cli(capsys, "run", EXAMPLE, "--out", out, *TINY, "--set", f"time.stop_time={stop_time}", *extra)


def front_from_phi(phi: np.ndarray, x_edges: np.ndarray, dz: float, threshold: float) -> float:
    """Right edge of the furthest column with sum(phi dz)/phi_max > threshold (written here)."""
    h = phi.sum(axis=1) * dz / PHI_MAX
    cols = np.nonzero(h > threshold)[0]
    return float(x_edges[cols[-1] + 1])


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("tiny") / "run"
    code = main(["run", str(EXAMPLE), "--out", str(out), *TINY, "--set", "time.stop_time=0.05"])
    return code, out


# --------------------------------------------------------------------------------------------
# Output of a completed run
# --------------------------------------------------------------------------------------------
def test_run_writes_a_self_describing_netcdf(tiny_run):
    code, out = tiny_run
    assert code == RunExit.COMPLETED
    with xr.open_dataset(out / "output.nc") as ds:
        for name in [*ds.data_vars, *ds.coords]:
            assert ds[name].attrs.get("units"), name
            assert ds[name].attrs.get("long_name") or name == "time", name
        assert ds["time"].attrs["units"] == "s"
        assert ds["x"].attrs["units"] == "m" and ds["z"].attrs["units"] == "m"
        assert set(ds.data_vars) >= {"phi", "c", "u", "w", "p", "p_f", "S"}
        assert ds["phi"].dims == ("time", "z", "x") and ds["phi"].shape[1:] == (6, 16)  # CF order
        # the material fraction holds the grains: phi <= phi_max c, and c = 0 where phi = 0
        phi, c = ds["phi"].values, ds["c"].values
        assert np.all(phi <= ds["phi"].attrs["phi_max"] * c + 1e-12) and np.all(c[phi == 0] == 0)
        assert 0.0 <= c.min() and c.max() <= 1.0
        assert ds.attrs["case_file"] == EXAMPLE.read_text()
        assert ds.attrs["granflow_version"] and "config_effective" in ds.attrs
        np.testing.assert_allclose(ds["time"].values, np.arange(6) * 0.01, rtol=0, atol=1e-12)
        # initial mass: phi0 H0 L0 (column 0.1 x 0.1 m at phi_max), exact to round-off
        dx, dz = 0.4 / 16, 0.15 / 6
        mass0 = float(ds["phi"][0].sum()) * dx * dz
        assert mass0 == pytest.approx(PHI_MAX * 0.1 * 0.1, rel=1e-13)
        assert np.all(ds["phi"].values <= PHI_MAX) and np.all(ds["phi"].values >= 0.0)


def test_run_writes_figures(tiny_run):
    _, out = tiny_run
    s = json.loads((out / "summary.json").read_text())
    assert s["figures"] == {"files": ["snapshots.png", "front.png"]}
    for name in s["figures"]["files"]:
        assert (out / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_summary_has_the_required_keys_and_consistent_values(tiny_run):
    _, out = tiny_run
    s = json.loads((out / "summary.json").read_text())
    assert REQUIRED_SUMMARY_KEYS <= set(s)
    assert s["status"] == "completed" and s["steps"] == 50 and s["rejected_steps"] == 0
    assert s["resolution"]["nx"] == 16 and s["resolution"]["nz"] == 6
    assert s["closure"]["closure"] == "drucker_prager"
    assert s["closure"]["parameters"]["delta_deg"] == 26.74
    assert abs(s["mass_rel_error"]) <= 1e-12
    assert 0.0 <= s["phi_min"] <= s["phi_max"] <= PHI_MAX
    with xr.open_dataset(out / "output.nc") as ds:
        edges = np.linspace(0.0, 0.4, 17)
        thr = s["front_position"]["threshold_m"]
        assert thr == pytest.approx(0.05 * 0.1, rel=1e-14)  # column_collapse default: 0.05 H0
        assert ds.attrs["front_threshold_m"] == thr
        fronts = [front_from_phi(ds["phi"][i].transpose("x", "z").values, edges, 0.025, thr)
                  for i in range(ds.sizes["time"])]
        assert s["front_position"]["x_m"] == pytest.approx(fronts, abs=1e-12)
        # one definition: the accessor, the x_front series and the summary give the same fronts
        assert ds.granflow.front_position().values.tolist() == pytest.approx(fronts, abs=1e-12)
        assert ds["x_front"].values.tolist() == pytest.approx(fronts, abs=1e-12)
        assert s["front_position"]["resolution_m"] == pytest.approx(0.4 / 16, rel=1e-12)
        assert s["runout_m"] == pytest.approx(fronts[-1] - fronts[0], abs=1e-12)
        assert float(ds.granflow.runout(threshold=thr)) == pytest.approx(s["runout_m"], abs=1e-12)
        assert float(ds.granflow.runout()) == pytest.approx(s["runout_m"], abs=1e-12)  # the run's threshold
        h_wall = float(ds["phi"].isel(time=-1, x=0).sum()) * 0.025 / PHI_MAX
        assert s["final_height_at_wall"] == pytest.approx(h_wall, rel=1e-12)
    assert (out / "checkpoints" / "checkpoint_00000050.npz").is_file()


def test_progress_lines_when_not_on_a_terminal(tmp_path, capsys):
    code, _, err = run_cli(capsys, "run", EXAMPLE, "--out", tmp_path / "p", "--set", "grid.nx=16",
                           "--set", "grid.nz=6", "--set", "time.stop_time=0.016",
                           "--set", "output.log_interval=1e-9")
    assert code == RunExit.COMPLETED
    lines = [ln for ln in err.splitlines() if ln.startswith("granflow: t = ")]
    assert len(lines) == 17  # before the first step, then one per step with a tiny log interval
    # (16 steps: past the WARMUP_MAX_STEPS window plus MIN_TIMED_STEPS, so the last lines are timed)
    # the first steps compile the kernels: no ETA until 3 steps are timed after them (issue 16 item 7)
    from granflow.cases.step_clock import MIN_TIMED_STEPS

    warm = [ln for ln in lines if "compiling kernels (once)" in ln]
    # the first 1 + MIN_TIMED_STEPS lines warm up; a step of the first WARMUP_MAX_STEPS that is
    # COMPILE_RATIO times slower than the next (a kernel first used later, or a stall of a shared
    # machine: seen once in CI at step 5) restarts the warm-up, so warm lines may come back later
    assert lines[:1 + MIN_TIMED_STEPS] == warm[:1 + MIN_TIMED_STEPS] and len(warm) >= 1 + MIN_TIMED_STEPS
    assert all("ETA" not in ln for ln in warm)
    timed = [ln for ln in lines if ln not in warm]
    assert timed and lines[-1] in timed
    assert all("steps/s" in ln and "ETA" in ln and "dt = " in ln for ln in timed)


def test_existing_output_needs_overwrite_or_restart(tiny_run, capsys, tmp_path):
    _, out = tiny_run
    code, _, err = run_cli(capsys, "run", EXAMPLE, "--out", out, *TINY)
    assert code == ExitCode.BAD_INPUT and "--overwrite" in err and len(err.strip().splitlines()) == 1
    assert "--out DIR" in err and "the grid must be the same" in err  # issue 16 item 3
    code, _, err = tiny(capsys, tmp_path / "o", 0.003)
    assert code == RunExit.COMPLETED
    code, _, err = tiny(capsys, tmp_path / "o", 0.002, "--overwrite")
    assert code == RunExit.COMPLETED
    assert [p.name for p in (tmp_path / "o" / "checkpoints").iterdir()] == ["checkpoint_00000002.npz"]


# --------------------------------------------------------------------------------------------
# Restart
# --------------------------------------------------------------------------------------------
N = 20


def _arrays(path: Path) -> dict[str, bytes]:
    arrays, _, _ = load_checkpoint(path)
    return {k: v.tobytes() for k, v in arrays.items()}


@pytest.mark.parametrize("predictor, sweeps, margin", [("previous", 10, 0), ("extrapolated", 10, 0),
                                                       ("extrapolated", 1, 0), ("extrapolated", 1, 2)])
def test_restart_is_bit_identical(tmp_path, capsys, predictor, sweeps, margin):
    """2N steps in one go versus N steps + restart from the step-N checkpoint + N steps (with the
    "extrapolated" Picard predictor the restart needs the checkpoint's state.accel; with one solve
    per step its state.free, granflow.active_set; with a velocity band margin the kept region and
    the matrix of PARDISO's kept analysis, granflow.region)."""
    a, b = tmp_path / "a", tmp_path / "b"
    pred = ["--set", f'numerics.picard.predictor="{predictor}"', "--set", f"numerics.picard.max_sweeps={sweeps}",
            "--set", f"numerics.ambient.velocity_band_margin={margin}"]
    if margin:  # a band narrower than the grid, so that the region and the analysis are kept
        pred += ["--set", "numerics.ambient.velocity_band=2", "--set", "grid.nx=40", "--set", "grid.nz=12"]
    ckpt = ["--set", f"output.checkpoint_interval={N}", "--set", "output.checkpoint_keep=10", *pred]
    assert tiny(capsys, a, 2 * N * 1e-3, *ckpt)[0] == RunExit.COMPLETED
    code, _, err = tiny(capsys, b, 2 * N * 1e-3, *pred, "--restart", a / "checkpoints" / f"checkpoint_{N:08d}.npz")
    assert code == RunExit.COMPLETED, err
    final_a = _arrays(a / "checkpoints" / f"checkpoint_{2 * N:08d}.npz")
    final_b = _arrays(b / "checkpoints" / f"checkpoint_{2 * N:08d}.npz")
    assert final_a.keys() == final_b.keys() and "state.phi" in final_a
    # what the step reads is saved, and only that: a^n, a^(n-1) for the extrapolation, the free set for one solve
    assert ({"state.accel", "state.accel_prev"} <= final_a.keys()) == (predictor == "extrapolated")
    assert ("state.accel" in final_a) == (predictor == "extrapolated")
    assert ("state.free" in final_a) == (sweeps == 1)
    for key in final_a:
        assert final_a[key] == final_b[key], key
    with netCDF4.Dataset(a / "output.nc") as da, netCDF4.Dataset(b / "output.nc") as db:
        ta, tb = da["time"][:], db["time"][:]
        later = ta > N * 1e-3 + 1e-12
        assert np.array_equal(ta[later], tb[tb > N * 1e-3 + 1e-12])
        for var in ("phi", "u", "w", "p", "S", "kinetic_energy"):
            assert da[var][later].tobytes() == db[var][db["time"][:] > N * 1e-3 + 1e-12].tobytes(), var
    sa, sb = (json.loads((d / "summary.json").read_text()) for d in (a, b))
    for key in ("energy_residual_rel", "runout_m", "mass_rel_error", "clipped_mass", "steps", "front_position"):
        assert sa[key] == sb[key], key


def test_restart_with_another_linear_solver_warns(tmp_path, capsys, caplog):
    a, b = tmp_path / "a", tmp_path / "b"
    ckpt = ["--set", "output.checkpoint_interval=5"]
    assert tiny(capsys, a, 5e-3, *ckpt, "--set", 'numerics.linear_solver="direct"')[0] == RunExit.COMPLETED
    _, _, meta = load_checkpoint(a / "checkpoints" / "checkpoint_00000005.npz")
    assert meta["linear_solver"] == "direct" and meta["velocity_band"] == 10
    with caplog.at_level("WARNING", logger="granflow.cases.runner"):
        code, _, err = tiny(capsys, b, 8e-3, "--restart", a / "checkpoints" / "checkpoint_00000005.npz",
                            "--set", "numerics.ambient.velocity_band=0")
    assert code == RunExit.COMPLETED, err
    assert "velocity_band = 10" in caplog.text and "not bit for bit" in caplog.text
    from granflow.solvers import pardiso_available

    if pardiso_available():  # auto resolves to pardiso on restart: a solver mismatch too
        assert "linear_solver = 'direct'" in caplog.text


# --------------------------------------------------------------------------------------------
# Test-only cases: Ctrl-C, KeyboardInterrupt from a callback, injected NaN
# --------------------------------------------------------------------------------------------
INTERRUPT_AT = {"step": None}
"""Step at which the test cases interrupt (None: never); reset by the tests."""


def _register(name: str, hook):
    def setup(config):
        sim = cc.setup(config)
        hook(sim)
        return sim

    CASES.register(name, setup_model=cc.ColumnCollapseSetup, check=cc.check,
                   summary="test-only")(setup)


def _raise_keyboard_interrupt(sim):
    def cb(s):
        if s.state.step == INTERRUPT_AT["step"]:
            INTERRUPT_AT["step"] = None  # once
            raise KeyboardInterrupt

    sim.add_callback(cb, IterationInterval(1), name="test_interrupt")


def _send_sigint(sim):
    def cb(s):
        if s.state.step == INTERRUPT_AT["step"]:
            INTERRUPT_AT["step"] = None
            signal.raise_signal(signal.SIGINT)  # the real Ctrl-C path: SIGINT handler of the CLI

    sim.add_callback(cb, IterationInterval(1), name="test_sigint")


def _inject_nan(sim):
    advance = sim.model.advance

    def bad_advance(state, dt):
        report = advance(state, dt)
        if state.step == INTERRUPT_AT["step"]:
            state.p[3, 1] = np.nan  # every attempt of this step ends non-finite
        return report

    sim.model.advance = bad_advance


@pytest.fixture
def test_cases():
    hooks = {"_test_keyboard_interrupt": _raise_keyboard_interrupt, "_test_sigint": _send_sigint,
             "_test_nan": _inject_nan}
    for name, hook in hooks.items():
        _register(name, hook)
    yield
    INTERRUPT_AT["step"] = None
    for name in hooks:
        CASES.unregister(name)


def _case_file(tmp_path: Path, name: str) -> Path:
    path = tmp_path / f"{name}.toml"
    path.write_text(EXAMPLE.read_text().replace('name = "column_collapse"', f'name = "{name}"'))
    return path


def _run_case(capsys, path, out, stop_time, *extra):
    return run_cli(capsys, "run", path, "--out", out, *TINY, "--set", f"time.stop_time={stop_time}", *extra)


@pytest.mark.parametrize("name", ["_test_keyboard_interrupt", "_test_sigint"])
def test_interrupt_writes_checkpoint_and_output_then_restart_matches(test_cases, tmp_path, capsys, name):
    path = _case_file(tmp_path, name)
    ref, out = tmp_path / "ref", tmp_path / "out"
    stop = 2 * N * 1e-3
    assert _run_case(capsys, path, ref, stop)[0] == RunExit.COMPLETED
    INTERRUPT_AT["step"] = N + 3  # between output times (every 10 steps)
    code, _, err = _run_case(capsys, path, out, stop)
    assert code == RunExit.INTERRUPTED, err
    assert "interrupted" in err and "--restart" in err and "Traceback" not in err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "interrupted" and summary["steps"] == N + 3
    via = "Ctrl-C" if name == "_test_sigint" else "KeyboardInterrupt"  # SIGINT: the CLI's handler
    assert summary["message"] == f"interrupted ({via})"
    assert (out / "checkpoints" / f"checkpoint_{N + 3:08d}.npz").is_file()
    with xr.open_dataset(out / "output.nc") as ds:  # the output so far: records up to t = 0.02 s
        np.testing.assert_allclose(ds["time"].values, [0.0, 0.01, 0.02], atol=1e-12)
    code, _, err = _run_case(capsys, path, out, stop, "--restart", out)
    assert code == RunExit.COMPLETED, err
    final_ref = _arrays(ref / "checkpoints" / f"checkpoint_{2 * N:08d}.npz")
    final = _arrays(out / "checkpoints" / f"checkpoint_{2 * N:08d}.npz")
    assert final.keys() == final_ref.keys()
    for key in final_ref:
        assert final[key] == final_ref[key], key
    with netCDF4.Dataset(ref / "output.nc") as dr, netCDF4.Dataset(out / "output.nc") as do:
        assert dr["time"][:].tobytes() == do["time"][:].tobytes()
        for var in ("phi", "u", "w", "p", "p_f", "S", "kinetic_energy", "x_front"):
            assert dr[var][:].tobytes() == do[var][:].tobytes(), var
    sr, so = (json.loads((d / "summary.json").read_text()) for d in (ref, out))
    for key in ("energy_residual_rel", "energy", "front_position", "runout_m", "t_rest", "clipped_mass"):
        assert sr[key] == so[key], key


def test_step_failure_exits_1_and_keeps_output_and_checkpoint(test_cases, tmp_path, capsys):
    path = _case_file(tmp_path, "_test_nan")
    INTERRUPT_AT["step"] = 12
    code, _, err = _run_case(capsys, path, tmp_path / "f", 0.05)
    assert code == RunExit.STEP_FAILURE
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err
    assert "step 12 at t = 0.011 s" in lines[0] and "non-finite p" in lines[0] and "x = " in lines[0]
    with xr.open_dataset(tmp_path / "f" / "output.nc") as ds:  # records on the output times
        np.testing.assert_allclose(ds["time"].values, [0.0, 0.01], atol=1e-12)
        assert np.all(np.isfinite(ds["p"].values))
    arrays, scalars, _ = load_checkpoint(tmp_path / "f" / "checkpoints" / "checkpoint_00000011.npz")
    assert scalars["state.step"] == 11 and np.all(np.isfinite(arrays["state.p"]))
    assert json.loads((tmp_path / "f" / "summary.json").read_text())["status"] == "failed"


def test_solver_failure_from_the_case_file_exits_1(tmp_path, capsys):
    """A Picard tolerance no step can meet: every attempt of step 1 fails (two sweeps: with one,
    fail_tol is not checked, there is no loop)."""
    code, _, err = tiny(capsys, tmp_path / "f", 0.05, "--set", "numerics.picard.max_sweeps=2",
                        "--set", "numerics.picard.fail_tol=1e-12")
    assert code == RunExit.STEP_FAILURE
    assert "step 1 at t = 0 s" in err and "Picard" in err and len(err.strip().splitlines()) == 1
    with xr.open_dataset(tmp_path / "f" / "output.nc") as ds:
        assert ds.sizes["time"] == 1
    assert (tmp_path / "f" / "checkpoints" / "checkpoint_00000000.npz").is_file()


def test_bad_restart_exits_2(tiny_run, tmp_path, capsys):
    _, out = tiny_run
    code, _, err = tiny(capsys, tmp_path / "r", 0.05, "--restart", tmp_path / "missing.npz")
    assert code == ExitCode.BAD_INPUT and "does not exist" in err
    code, _, err = run_cli(capsys, "run", EXAMPLE, "--out", tmp_path / "r2", "--quiet", "--set", "grid.nx=20",
                           "--set", "grid.nz=6", "--restart", out)
    assert code == ExitCode.BAD_INPUT and "grid" in err and len(err.strip().splitlines()) == 1


def test_max_steps_counts_from_t0_across_a_restart(tmp_path, capsys):
    out = tmp_path / "m"
    assert tiny(capsys, out, 1.0, "--set", "time.max_steps=7")[0] == RunExit.COMPLETED
    assert json.loads((out / "summary.json").read_text())["steps"] == 7
    code, _, err = tiny(capsys, out, 1.0, "--set", "time.max_steps=9", "--restart", out)
    assert code == RunExit.COMPLETED, err
    s = json.loads((out / "summary.json").read_text())
    assert s["steps"] == 9 and s["t_final"] == pytest.approx(0.009, abs=1e-12)
    with xr.open_dataset(out / "output.nc") as ds:  # records 0, 0.007 (end of run 1), 0.009
        np.testing.assert_allclose(ds["time"].values, [0.0, 0.007, 0.009], atol=1e-12)


def test_terminal_progress_line_is_rewritten_in_place(monkeypatch):
    """Without rich (import blocked here), a terminal gets one line redrawn with \\r."""
    import io
    import sys

    from granflow.cases.runner import Progress
    from granflow.cli.run import ProgressPrinter

    monkeypatch.setitem(sys.modules, "rich.console", None)
    stream = io.StringIO()
    printer = ProgressPrinter(stream, log_interval=10.0, tty=True)
    printer(Progress(t=0.25, stop_time=1.0, dt=1e-3, step=250, steps_per_s=50.0, eta_s=15.0, wall_s=5.0))
    printer.close()
    text = stream.getvalue()
    assert text.startswith("\rt = 0.25/1 s  step 250  dt = 0.001 s  50.0 steps/s") and text.endswith("\n")
    assert "ETA 0:00:15" in text and "wall 0:00:05" in text


def test_flagship_fluidised_example_smoke(capsys, tmp_path):
    """The README's first command on a tiny grid: runs, keeps a pore pressure, writes figures."""
    flagship = EXAMPLE.with_name("column_collapse_fluidised.toml")
    out = tmp_path / "fl"
    code, _, err = run_cli(capsys, "run", flagship, "--out", out, *TINY, "--set", "time.stop_time=0.03")
    assert code == RunExit.COMPLETED, err
    s = json.loads((out / "summary.json").read_text())
    assert s["status"] == "completed" and abs(s["mass_rel_error"]) <= 1e-12
    with xr.open_dataset(out / "output.nc") as ds:
        pf0 = ds["p_f"][0].transpose("x", "z").values
        # b0 = 0.9 of the lithostatic pressure of a column at phi0 = 0.58: basal cell centre value.
        dz = 0.15 / 6
        expected = 0.9 * 0.58 * 2500.0 * 9.81 * (0.1 - dz / 2)
        assert pf0[0, 0] == pytest.approx(expected, rel=1e-10)
        assert float(ds["p_f"][-1].max()) > 0.0
    assert (out / "snapshots.png").exists()
