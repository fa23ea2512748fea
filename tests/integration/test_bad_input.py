"""Issue 17: the checks behind the fuzz test (tests/integration/test_fuzz_commands.py) that need more than
"exit 2, one line": what they still accept, what they print, and the parts a fuzzed input cannot
reach (a warning during a run, an unreachable scheduler, the memory estimate, truncated files of
every classic NetCDF format)."""
from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import netCDF4
import numpy as np
import pytest

from granflow.cases import memory
from granflow.cli import main
from granflow.config import MAX_STEPS, CaseConfig
from granflow.errors import GranflowInputError
from granflow.output.integrity import check_complete
from granflow.output.paths import check_directory, check_file
from granflow.safe_toml import MAX_NESTING, loads, loads_value

from _scripts import ROOT  # noqa: E402  (the repository; tests/ holds tiers)
EXAMPLE = ROOT / "examples" / "column_collapse_dry.toml"
TINY = ["--set", "grid.nx=10", "--set", "grid.nz=6", "--set", "time.stop_time=0.004",
        "--set", "output.figures=false", "--quiet"]


def _cfg(**sections):
    return CaseConfig.from_dict({"case": {"name": "column_collapse"}, **sections})


# ------------------------------------------------------------------------------ writability
def test_writable_locations_are_accepted_and_nothing_is_created(tmp_path):
    new = tmp_path / "a" / "b" / "c"
    assert check_directory(new, "--out") == new
    assert check_file(tmp_path / "x" / "y.png", "--out").name == "y.png"
    assert not (tmp_path / "a").exists() and not (tmp_path / "x").exists()
    assert sorted(os.listdir(tmp_path)) == []  # the probe left nothing


@pytest.mark.parametrize("make, expected", [
    (lambda p: (p / "f").write_text("x") and p / "f", "not a directory"),
    (lambda p: (p / "f").write_text("x") and p / "f" / "sub", "is not a directory"),
    (lambda p: Path("/proc/granflow_test"), "cannot write"),
    (lambda p: Path("/dev/null"), "not a directory"),
])
def test_unwritable_directories_are_refused(tmp_path, make, expected):
    with pytest.raises(GranflowInputError, match=expected):
        check_directory(make(tmp_path), "--out")


# ------------------------------------------------------------------------------ TOML limits
def test_nesting_at_the_limit_is_accepted_and_one_more_is_refused():
    ok = "[" * (MAX_NESTING - 1) + "]" * (MAX_NESTING - 1)
    assert loads(f"v = {ok}", "f") is not None
    deep = "[" * (MAX_NESTING + 1) + "]" * (MAX_NESTING + 1)
    with pytest.raises(GranflowInputError, match="nested more than"):
        loads(f"v = {deep}", "f")
    assert loads_value("[1, 2]", "k") == [1, 2] and loads_value("word", "k") == "word"
    with pytest.raises(GranflowInputError, match="--set k: number with more than 4300 digits"):
        loads_value("1" * 4400, "k")
    with pytest.raises(GranflowInputError, match="out of range"):
        loads_value(str(2**64), "k")


# ------------------------------------------------------------------------------ schema checks
def test_allow_unphysical_lifts_the_physical_ranges_only():
    with pytest.raises(GranflowInputError, match="material.rho_s.*case.allow_unphysical"):
        _cfg(material={"rho_s": 1e6})
    cfg = _cfg(case={"name": "column_collapse", "allow_unphysical": True}, material={"rho_s": 1e6},
               gravity={"g": 1e3})
    assert cfg.material.rho_s == 1e6 and cfg.gravity.g == 1e3
    with pytest.raises(GranflowInputError, match="material.d: grain diameter 0.5 m is not smaller"):
        _cfg(case={"name": "column_collapse", "allow_unphysical": True}, material={"d": 0.5})


def test_step_budget_names_both_numbers_and_max_steps_is_an_explicit_budget():
    with pytest.raises(GranflowInputError) as err:
        _cfg(time={"stop_time": 1.5, "dt_max": 1e-300})
    assert "time.dt_max" in str(err.value) and "1.5e+300" in str(err.value) and str(MAX_STEPS) in str(err.value)
    assert _cfg(time={"stop_time": 1.5, "dt_max": 1e-300, "max_steps": 10}).time.max_steps == 10
    assert _cfg(time={"stop_time": 1.0, "dt_max": 1.0 / MAX_STEPS}).time.dt_max > 0  # at the limit


def test_negative_yield_is_refused_but_dilatant_drucker_prager_is_not():
    with pytest.raises(GranflowInputError, match="closure.expression: the yield function is negative"):
        _cfg(closure={"name": "generic", "expression": "-1 - I"})
    # Z < 0 below I_eq/4.66 off the equilibrium line only: a valid closure
    assert _cfg(closure={"name": "drucker_prager_dilatancy"}).closure.name == "drucker_prager_dilatancy"


def test_numbers_as_text_are_refused_in_closures_and_materials():
    from granflow.rheology import make_closure

    with pytest.raises(GranflowInputError, match="delta_phi"):
        make_closure("mu_i", material={"delta_phi": "0.2"})
    with pytest.raises(GranflowInputError, match="coefficients"):
        make_closure("power_law", coefficients=["0.4", "0.2"])
    assert make_closure("power_law", coefficients=[0.4, 0.2]).coefficients == (0.4, 0.2)
    assert make_closure("generic", expression="0.4 + 0.2*I").name == "generic"  # text where text is due


# ------------------------------------------------------------------------------ memory
def test_memory_estimate_refuses_with_the_estimate(monkeypatch, tmp_path, capsys):
    monkeypatch.setattr(memory, "available_memory", lambda: 4_000_000_000)
    code = main(["run", str(EXAMPLE), "--out", str(tmp_path / "o"), "--quiet",
                 "--set", "grid.nx=1000", "--set", "grid.nz=1000"])
    err = capsys.readouterr().err
    assert code == 2 and "1000000 cells need about 10.3 GB" in err and "4 GB" in err
    assert not (tmp_path / "o").exists()
    memory.check_memory(_cfg(grid={"nx": 1000, "nz": 1000}), available=20_000_000_000)  # fits


def test_available_memory_is_read():
    have = memory.available_memory()
    assert have is None or have > 0


# ------------------------------------------------------------------------------ runs
@pytest.fixture(scope="module")
def mu_i_run(tmp_path_factory):
    """A tiny mu(I) run (its checkpoint is continued with other physics below)."""
    root = tmp_path_factory.mktemp("mu_i")
    case = root / "mu_i.toml"
    case.write_text(EXAMPLE.read_text().replace('name = "drucker_prager"', 'name = "mu_i"')
                    .replace("delta_deg = 26.74", ""))
    assert main(["run", str(case), "--out", str(root / "run"), *TINY]) == 0
    return case, root / "run"


def test_restart_of_mu_i_into_drucker_prager_is_refused_and_into_mu_i_continues(mu_i_run, tmp_path, capsys):
    case, run = mu_i_run
    code = main(["run", str(EXAMPLE), "--out", str(tmp_path / "dp"), *TINY, "--restart", str(run)])
    err = capsys.readouterr().err
    assert code == 2 and "other physics" in err and "closure.name: 'mu_i' in the checkpoint" in err
    assert not (tmp_path / "dp").exists()
    code = main(["run", str(case), "--out", str(tmp_path / "mu"), *TINY, "--set", "time.stop_time=0.006",
                 "--restart", str(run)])
    assert code == 0, capsys.readouterr().err


def test_negative_phi_eq_reached_in_a_run_warns_once(mu_i_run, tmp_path, monkeypatch, caplog):
    from granflow.materials import Material

    case, _ = mu_i_run
    monkeypatch.setattr(Material, "inertial_number", lambda self, S, p: np.full(np.shape(S), 5.0))
    with caplog.at_level("WARNING", logger="granflow.cases.runner"):
        assert main(["run", str(case), "--out", str(tmp_path / "w"), *TINY]) == 0
    summary = json.loads((tmp_path / "w" / "summary.json").read_text())
    phi_eq = [w for w in summary["warnings"] if "phi_eq(I)" in w]  # others (e.g. Picard) may follow
    assert len(phi_eq) == 1 and "phi_eq(I) = -0.4 < 0 at I = 5" in phi_eq[0]
    assert caplog.text.count("phi_eq(I)") == 1


def test_negative_phi_eq_is_not_reported_for_an_isochoric_closure(mu_i_run, tmp_path, monkeypatch):
    """f = 0 never reads phi_eq: the same forced I = 5 as above gives no warning."""
    from granflow.materials import Material

    case, _ = mu_i_run
    monkeypatch.setattr(Material, "inertial_number", lambda self, S, p: np.full(np.shape(S), 5.0))
    out = tmp_path / "iso"
    assert main(["run", str(case), "--out", str(out), *TINY, "--set", 'closure.name="incompressible"']) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert not [w for w in summary["warnings"] if "phi_eq(I)" in w], summary["warnings"]


def test_unreachable_scheduler_writes_nothing(tmp_path, capsys):
    dask = pytest.importorskip("dask")
    pytest.importorskip("distributed")
    base = tmp_path / "case.toml"
    base.write_text(EXAMPLE.read_text())
    sweep = tmp_path / "sweep.toml"
    sweep.write_text('[sweep]\nbase = "case.toml"\n[parameters]\n"setup.H0" = { values = [0.1, 0.09] }\n')
    with dask.config.set({"distributed.comm.timeouts.connect": "1s"}):
        code = main(["sweep", str(sweep), "--out", str(tmp_path / "sw"), "--scheduler", "tcp://127.0.0.1:1"])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1 and "--scheduler" in err, err
    assert not (tmp_path / "sw").exists()


# ------------------------------------------------------------------------------ truncated output
@pytest.mark.parametrize("fmt", ["NETCDF3_CLASSIC", "NETCDF3_64BIT_OFFSET", "NETCDF3_64BIT_DATA", "NETCDF4"])
def test_truncated_netcdf_is_refused_in_every_format(tmp_path, fmt):
    path = tmp_path / "f.nc"
    with netCDF4.Dataset(path, "w", format=fmt) as ds:
        ds.createDimension("time", None)
        ds.createDimension("x", 5)
        ds.title = "t"
        ds.createVariable("x", "f8", ("x",))[:] = np.arange(5.0)
        ds.createVariable("time", "f8", ("time",))[:] = np.arange(3.0)
        ds.createVariable("phi", "f4", ("time", "x"))[:] = np.ones((3, 5))
    check_complete(path)  # whole
    cut = tmp_path / "cut.nc"
    shutil.copy(path, cut)
    os.truncate(cut, path.stat().st_size - 4)
    if fmt == "NETCDF4":  # HDF5 refuses the file itself (plot/export: "not a readable NetCDF file")
        with pytest.raises(OSError):
            netCDF4.Dataset(cut).close()
    else:
        with pytest.raises(GranflowInputError, match=r"truncated: .*\(3 records, only the first 2 complete\)"):
            check_complete(cut)


def test_derivation_time_budget_is_bad_input_and_a_normal_derivation_fits(monkeypatch):
    from granflow.rheology import derive

    assert derive.derive_dilatancy("0.38 + 0.27*I/(I + 0.3)").f is not None
    import time

    monkeypatch.setattr(derive, "DERIVE_TIME_BUDGET_S", 0.05)
    monkeypatch.setattr(derive, "_derive", lambda Z, simplify: time.sleep(5))  # a SymPy that never ends
    t0 = time.monotonic()
    with pytest.raises(GranflowInputError, match="did not finish within 0.05 s"):
        derive.derive_dilatancy("0.4 + I")
    assert time.monotonic() - t0 < 2


@pytest.mark.parametrize("expr, fragment", [("sqrt(-1)", "not real"), ("exp(1000)", "exp(1000)"),
                                            ("I**1e10", "exponent"), ("(1 + I)**200", "exponent")])
def test_expressions_sympy_cannot_handle_are_refused_fast(expr, fragment):
    from granflow.rheology.derive import parse_yield_function

    with pytest.raises(GranflowInputError, match=fragment.replace("(", r"\(").replace(")", r"\)")):
        parse_yield_function(expr)
    assert parse_yield_function("(1 + I)**3 + exp(-1000)").free_symbols


def test_memory_limit_environment_variable_overrides_the_available_memory(monkeypatch):
    cfg = _cfg(grid={"nx": 200, "nz": 200})  # estimate 0.7 GB
    monkeypatch.setattr(memory, "available_memory", lambda: 100_000_000_000)
    memory.check_memory(cfg)
    monkeypatch.setenv(memory.MEMORY_LIMIT_ENV, "0.5")
    with pytest.raises(GranflowInputError, match=r"0\.7 GB .*0\.5 GB of the limit GRANFLOW_MEMORY_LIMIT"):
        memory.check_memory(cfg)
    monkeypatch.setattr(memory, "available_memory", lambda: 1_000_000)  # a small machine, raised limit
    monkeypatch.setenv(memory.MEMORY_LIMIT_ENV, "1000")
    memory.check_memory(cfg)
    for bad in ("lots", "-1", "nan", "0"):
        monkeypatch.setenv(memory.MEMORY_LIMIT_ENV, bad)
        with pytest.raises(GranflowInputError, match="GRANFLOW_MEMORY_LIMIT"):
            memory.check_memory(cfg)


def test_a_pole_of_the_yield_function_between_the_samples_is_refused():
    with pytest.raises(GranflowInputError, match=r"closure.expression: .*singular at I = 0.5"):
        _cfg(closure={"name": "generic", "expression": "0.4 + 1/(I - 0.5)**2"})
    assert _cfg(closure={"name": "generic", "expression": "0.4 + 1/(I + 0.5)**2"}).closure.name == "generic"
