"""``granflow sweep``: sweep files, member validation before any run, a sweep on a
``distributed.LocalCluster`` started here (passed with ``--scheduler``), a member that fails at run
time, and the re-run that skips finished members.

The base case is a fluidised column collapse (the flagship example's physics) on a 16 x 6 grid
for 0.02 s (20 steps of 1 ms). The member that fails gets a Picard tolerance no step can meet
(``max_sweeps = 2``, ``fail_tol = 1e-12``: the loop stops unconverged at its cap; see
tests/integration/test_run.py). Independent checks: the front
and run-out recomputed here from each member's NetCDF phi (deposit thickness
sum(phi dz)/phi_max > one cell height, right edge of the furthest such column; NUMERICS.md §10),
exact to 1e-12 m; the initial pore pressure ratio p_f/(p + p_f) = b0 in the grains of record 0
(rel. 1e-12), which shows each member ran with its own override.
"""
from __future__ import annotations

import csv
import json
import re
from pathlib import Path

import netCDF4
import numpy as np
import pytest

from granflow.cli import ExitCode, main
from granflow.output import ordered

from _scripts import ROOT, terminal_sigint  # noqa: E402  (the repository; tests/ holds tiers)
NX, NZ, LX, LZ = 16, 6, 0.4, 0.15
PHI_MAX = 0.6
PHI_C = 0.3  # numerics.ambient.phi_c default: grains vs ambient
B0 = [0.0, 0.5, 0.9]
FAILING = "m0002"
TINY_CASE = f"""
[case]
name = "column_collapse"
[setup]
H0 = 0.1
L0 = 0.1
phi0 = 0.58
b0 = 0.9
[material]
d = 70e-6
rho_s = 2500.0
phi_max = {PHI_MAX}
[closure]
name = "drucker_prager"
delta_deg = 26.74
[gas]
law = "linear"
[grid]
nx = {NX}
nz = {NZ}
Lx = {LX}
Lz = {LZ}
[time]
stop_time = 0.02
dt_max = 1e-3
[output]
interval = 0.01
figures = false
"""
SWEEP = """
[sweep]
base = "case.toml"
mode = "zip"

[parameters]
"setup.b0" = { values = [0.0, 0.5, 0.9] }
"numerics.picard.max_sweeps" = { values = [4, 4, 2] }
"numerics.picard.fail_tol" = { values = [0.5, 0.5, 1e-12] }
"""


def write_sweep(tmp_path: Path, sweep: str = SWEEP, case: str = TINY_CASE) -> Path:
    (tmp_path / "case.toml").write_text(case)
    path = tmp_path / "sweep.toml"
    path.write_text(sweep)
    return path


def run_cli(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def read_table(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def fronts_from_nc(path: Path) -> list[float]:
    """Front at every record, from phi alone (written here, NUMERICS.md §10)."""
    edges = np.linspace(0.0, LX, NX + 1)
    dz = LZ / NZ
    with netCDF4.Dataset(path) as ds:
        phi = ordered(ds["phi"]).astype(float)  # (time, x, z)
    out = []
    for rec in phi:
        h = rec.sum(axis=1) * dz / PHI_MAX
        cols = np.nonzero(h > dz)[0]  # default threshold: one cell height
        out.append(float(edges[cols[-1] + 1]))
    return out


@pytest.fixture(scope="module")
def cluster():
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=":0") as c:
        yield c


# ------------------------------------------------------------------------------ the sweep
def test_sweep_on_a_local_cluster_records_the_failure_and_resumes(tmp_path, capsys, cluster):
    sweep = write_sweep(tmp_path)
    out = tmp_path / "out"
    code, stdout, stderr = run_cli(capsys, "sweep", sweep, "--out", out,
                                   "--scheduler", cluster.scheduler_address)
    assert code == ExitCode.FAILED, stderr
    rows = read_table(out / "sweep_summary.csv")
    assert [r["member_id"] for r in rows] == ["m0000", "m0001", FAILING]
    assert [float(r["setup.b0"]) for r in rows] == B0
    for row, b0 in zip(rows, B0, strict=True):
        mdir = out / row["member_id"]
        nc = mdir / "run" / "output.nc"
        with netCDF4.Dataset(nc) as ds:  # record 0: the member's own initial pore pressure
            phi, p, p_f = (np.asarray(ds[v][0], dtype=float) for v in ("phi", "p", "p_f"))
        grains = (phi >= PHI_C) & (p + p_f > 0)
        assert grains.sum() > 0
        np.testing.assert_allclose(p_f[grains] / (p + p_f)[grains], b0, rtol=1e-12, atol=1e-15)
        assert row["cached"] == "False"
        if row["member_id"] == FAILING:
            assert row["status"] == "failed"
            assert "MemberRunFailed" in row["error"] and "Picard" in row["error"]
            assert "step 1" in row["error"]
            assert not (mdir / "summary.json").exists()
            err = json.loads((mdir / "error.json").read_text())
            assert "Picard" in err["error"] and "run_member" in err["traceback"]
            assert json.loads((mdir / "run" / "summary.json").read_text())["status"] == "failed"
            assert row["runout_m"] == ""
        else:
            assert row["status"] == "ok" and row["error"] == ""
            fronts = fronts_from_nc(nc)
            assert float(row["runout_m"]) == pytest.approx(fronts[-1] - fronts[0], abs=1e-12)
            assert float(row["t_final"]) == pytest.approx(0.02, abs=1e-12)
            assert int(row["steps"]) == 20 and row["summary.status"] == "completed"
            assert float(row["case_diagnostics.b0"]) == b0
            summary = json.loads((mdir / "summary.json").read_text())
            assert summary["runout_m"] == float(row["runout_m"])
            assert (mdir / "run" / "case.toml").is_file()

    # the printed table: one line per member with id, overrides, status, run-out
    lines = stdout.splitlines()
    assert lines[0].split() == ["member", "overrides", "status", "run-out", "[m]"]
    for line, row, b0 in zip(lines[1:], rows, B0, strict=True):
        assert line.startswith(row["member_id"]) and f"setup.b0={b0:g}" in line
        status = "failed" if row["member_id"] == FAILING else "ok"
        assert re.search(rf"\s{status}\s", line + " ")
        if status == "ok":
            assert line.split()[-1] == f"{float(row['runout_m']):.4g}"
    assert sum(f"member {FAILING} failed" in ln for ln in stderr.splitlines()) == 1

    # re-run: finished members are skipped (outputs untouched), the failed one runs again
    stamps = {m: (out / m / "run" / "output.nc").stat().st_mtime_ns for m in ("m0000", "m0001")}
    err_stamp = (out / FAILING / "error.json").stat().st_mtime_ns
    code, stdout, stderr = run_cli(capsys, "sweep", sweep, "--out", out,
                                   "--scheduler", cluster.scheduler_address)
    assert code == ExitCode.FAILED
    rows2 = read_table(out / "sweep_summary.csv")
    assert [(r["status"], r["cached"]) for r in rows2] == [("ok", "True"), ("ok", "True"),
                                                           ("failed", "False")]
    assert [r["runout_m"] for r in rows2] == [r["runout_m"] for r in rows]
    for m, stamp in stamps.items():
        assert (out / m / "run" / "output.nc").stat().st_mtime_ns == stamp, m
    assert (out / FAILING / "error.json").stat().st_mtime_ns > err_stamp
    assert stdout.count("ok (cached)") == 2


def test_default_local_cluster_and_all_cached_rerun(tmp_path, capsys):
    """Without --scheduler the sweep starts (and closes) its own cluster; exit 0 when every member
    completed, also on a re-run where all are cached (no cluster needed)."""
    pytest.importorskip("distributed")
    sweep = write_sweep(tmp_path, '[sweep]\nbase = "case.toml"\n[parameters]\n'
                                  '"setup.b0" = { values = [0.5] }\n')
    for cached in (False, True):
        code, _, stderr = run_cli(capsys, "sweep", sweep, "--out", tmp_path / "o",
                                  "--workers", "1")
        assert code == ExitCode.OK, stderr
        row, = read_table(tmp_path / "o" / "sweep_summary.csv")
        assert (row["status"], row["cached"]) == ("ok", str(cached))
        assert "1 of 1 member(s) completed" in stderr


# ------------------------------------------------------------------------------ bad input
def _bad(tmp_path, capsys, sweep: str, *extra, case: str = TINY_CASE):
    path = write_sweep(tmp_path, sweep, case)
    out = tmp_path / "never"
    code, stdout, stderr = run_cli(capsys, "sweep", path, "--out", out, *extra)
    assert code == ExitCode.BAD_INPUT, stderr
    assert len(stderr.strip().splitlines()) == 1 and stderr.startswith("granflow: error: ")
    assert "Traceback" not in stderr and stdout == ""
    assert not out.exists()  # nothing ran, nothing written
    return stderr


GOOD_PARAMS = '[parameters]\n"setup.b0" = { values = [0.0, 0.5] }\n'


@pytest.mark.parametrize("sweep, culprits", [
    ('[sweep]\nbase = "case.toml"\nsedd = 1\n' + GOOD_PARAMS, ["'sedd'"]),
    ('[sweep]\nbase = "case.toml"\n' + GOOD_PARAMS + "[extra]\na = 1\n", ["'extra'"]),
    ('[sweep]\nbase = "case.toml"\n[parameters]\n"setup.b0" = { valuse = [0.5], values = [1] }\n',
     ["'valuse'", "setup.b0"]),
    ('[sweep]\nbase = "case.toml"\n[parameters]\n"setup.b0" = 0.5\n', ["setup.b0", "table"]),
    ('[sweep]\nbase = "missing.toml"\n' + GOOD_PARAMS, ["missing.toml"]),
    (GOOD_PARAMS, ["[sweep]"]),
    ('[sweep]\nbase = "case.toml"\n', ["[parameters]"]),
    (('[sweep]\nbase = "case.toml"\nmode = "zip"\n[parameters]\n"setup.b0" = { values = [0.0, 0.5] }\n'
      '"setup.H0" = { values = [0.1] }\n'), ["equally"]),
    ('[sweep]\nbase = "case.toml"\nmode = "random"\n' + GOOD_PARAMS, ["mode"]),
    ('[sweep]\nbase = "case.toml"\n[parameters]\n"stup.b0" = { values = [0.5] }\n', ["'stup'"]),
    ('[sweep]\nbase = "case.toml"\nmode = "lhs"\n[parameters]\n"setup.b0" = { lhs = [0.0, 0.9] }\n',
     ["samples", "seed"]),
])
def test_sweep_file_errors_name_the_key(tmp_path, capsys, sweep, culprits):
    err = _bad(tmp_path, capsys, sweep)
    for culprit in culprits:
        assert culprit in err, (culprit, err)


def test_every_member_is_validated_before_any_run(tmp_path, capsys):
    sweep = ('[sweep]\nbase = "case.toml"\n[parameters]\n'
             '"setup.b0" = { values = [0.5, 1.5] }\n"setup.H0" = { values = [0.1, 0.3] }\n')
    err = _bad(tmp_path, capsys, sweep)
    # grid order m0000 (0.5, 0.1) m0001 (0.5, 0.3) m0002 (1.5, 0.1) m0003 (1.5, 0.3)
    assert "3 of 4 member(s) invalid" in err and "m0000" not in err
    assert "member m0001 (setup.b0=0.5 setup.H0=0.3): setup.H0:" in err  # taller than the box
    assert "member m0002 (setup.b0=1.5 setup.H0=0.1): " in err and "setup.b0: Input should be" in err
    err = _bad(tmp_path, capsys, '[sweep]\nbase = "case.toml"\n[parameters]\n'
               '"grid.nx" = { range = [16, 32], n = 2 }\n')  # floats for an integer
    assert "member m0000 (grid.nx=16): " in err and "grid.nx: Input should be a valid integer" in err
    err = _bad(tmp_path, capsys, '[sweep]\nbase = "case.toml"\n[parameters]\n'
               '"setup.bo" = { values = [0.5] }\n')
    assert "member m0000" in err and "setup.bo: unknown key" in err
    err = _bad(tmp_path, capsys, SWEEP, case=TINY_CASE.replace("nx = 16", "nx = 0"))
    assert "grid.nx" in err and "member m0000" in err


def test_workers_option_errors(tmp_path, capsys):
    assert "--workers" in _bad(tmp_path, capsys, SWEEP, "--workers", "0")
    assert "--scheduler" in _bad(tmp_path, capsys, SWEEP, "--workers", "2",
                                 "--scheduler", "tcp://127.0.0.1:1")


# ------------------------------------------------------------------------------ the file format
def test_nested_parameter_tables_equal_dotted_keys(tmp_path):
    from granflow.cli.sweep import load_sweep

    dotted, _ = load_sweep(write_sweep(tmp_path, SWEEP))
    nested_text = ('[sweep]\nbase = "case.toml"\nmode = "zip"\n[parameters.setup]\n'
                   'b0 = { values = [0.0, 0.5, 0.9] }\n[parameters.numerics.picard]\n'
                   'max_sweeps = { values = [4, 4, 2] }\nfail_tol = { values = [0.5, 0.5, 1e-12] }\n')
    nested, _ = load_sweep(write_sweep(tmp_path, nested_text))
    assert nested.members() == dotted.members()
    assert [o["setup.b0"] for _, o in dotted.members()] == B0


def test_example_sweep_is_valid():
    """examples/sweep_column.toml: the fluidised flagship over b0 in {0, 0.5, 0.9}, every member
    a valid case (b0 = 0 with gas.law = "linear" is allowed)."""
    import tomllib

    from granflow.cli.sweep import load_sweep, validate_members

    spec, base = load_sweep(ROOT / "examples" / "sweep_column.toml")
    assert base.resolve() == (ROOT / "examples" / "column_collapse_fluidised.toml").resolve()
    assert validate_members(spec) == 3
    assert [o for _, o in spec.members()] == [{"setup.b0": b} for b in B0]
    flagship = tomllib.loads(base.read_text())
    for _, overrides in spec.members():
        config = spec.config(overrides)
        assert config["gas"]["law"] == flagship["gas"]["law"] == "linear"
        assert config["setup"] == {**flagship["setup"], "b0": overrides["setup.b0"]}
        # everything else is the flagship's (plus empty tables of defaulted sections)
        assert {k: v for k, v in config.items() if k != "setup" and v != {}} == \
            {k: v for k, v in flagship.items() if k != "setup"}


def test_sweep_reports_progress_and_closes_its_cluster_cleanly(tmp_path, capsys):
    """Issue 16 item 7: a line per finished member with the count done (the sweep was silent
    until the end) and no "Worker process still alive ... killing" at the shutdown of the local
    cluster (distributed logs it through logging; captured here with the log records)."""
    import logging

    sweep = write_sweep(tmp_path)
    records = []

    class Keep(logging.Handler):
        def emit(self, record):
            records.append(record.getMessage())

    handler = Keep(level=logging.WARNING)
    logging.getLogger("distributed").addHandler(handler)
    try:
        code, _, stderr = run_cli(capsys, "sweep", sweep, "--out", tmp_path / "out", "--workers", "2")
    finally:
        logging.getLogger("distributed").removeHandler(handler)
    assert code == ExitCode.FAILED  # the sweep file has one failing member
    done = [ln for ln in stderr.splitlines() if ln.startswith("granflow: sweep: m")]
    assert len(done) == 3
    assert sorted(int(re.search(r"\((\d)/3 done", ln).group(1)) for ln in done) == [1, 2, 3]
    assert sum(f"{FAILING} failed" in ln for ln in done) == 1
    assert not [m for m in records if "still alive" in m], records


def test_sweep_display_lines():
    import io

    from granflow.cli.sweep import SweepDisplay
    from granflow.sweep import SweepProgress

    stream = io.StringIO()
    display = SweepDisplay(stream, tty=False)
    display(SweepProgress(None, None, 0, 3, 12.0, {"m0000": {"t": 0.1, "stop_time": 0.5, "warming_up": False},
                                                    "m0001": {"t": 0.0, "stop_time": 0.5, "warming_up": True}}, {}))
    display(SweepProgress("m0000", "ok", 1, 3, 70.0, {}, {"runout_m": 0.1234}))
    lines = stream.getvalue().splitlines()
    assert lines[0] == ("granflow: sweep: 0/3 done, 0:00:12 elapsed; running: m0000 t = 0.1/0.5, "
                        "m0001 t = 0/0.5 (compiling kernels, once)")
    assert lines[1] == "granflow: sweep: m0000 ok (1/3 done, 0:01:10 elapsed): run-out 0.1234 m"
    display(SweepProgress("m0001", "ok", 2, 3, 80.0, {}, {"runout_m": 0.2, "still_moving": True, "steps": 728,
                                                          "picard.not_converged_steps": 136}))
    assert stream.getvalue().splitlines()[2] == (
        "granflow: sweep: m0001 ok (2/3 done, 0:01:20 elapsed): run-out 0.2 m (still moving: not final); "
        "Picard not converged in 136 of 728 steps")


# ------------------------------------------------------------------------------ Ctrl-C (issue 16 item 7)
LONG_SWEEP = """
[sweep]
base = "case.toml"
mode = "grid"

[parameters]
"setup.b0" = { values = [0.0, 0.5, 0.9] }
"""


def test_member_progress_stops_the_run_when_the_sweep_is_stopped(tmp_path):
    from types import SimpleNamespace

    from granflow.cases.sweep_member import MemberProgress
    from granflow.sweep import STOP_FILE, run_member_task

    asked = []
    member = tmp_path / "m0000"
    member.mkdir()
    progress = MemberProgress(member, request_stop=asked.append)
    p = SimpleNamespace(t=0.1, stop_time=1.0, step=3, wall_s=1.0, warming_up=False)
    progress(p)
    assert asked == [] and json.loads((member / "progress.json").read_text())["step"] == 3
    (tmp_path / STOP_FILE).write_text("Ctrl-C\n")
    progress._last = -float("inf")
    progress(p)
    assert asked == ["the sweep was stopped (Ctrl-C)"]

    def never(config, outdir):  # a queued member must not start once the sweep is stopped
        raise AssertionError("started")

    status, record = run_member_task(never, {}, str(tmp_path / "m0001"))
    assert status == "failed" and "not run: the sweep was interrupted" in record["error"]
    assert not (tmp_path / "m0001").exists()


def test_ctrl_c_on_the_terminal_stops_the_sweep_cleanly(tmp_path):
    """SIGINT to the whole foreground process group, as a terminal's Ctrl-C sends it: the workers
    ignore it (they used to die with pages of tracebacks, and 'Worker process still alive ...
    killing' 48 s later); the running members stop after their step, the queued one does not
    start; exit 130 within seconds, one line saying how to finish (re-running is the resume test
    above: members without summary.json run again)."""
    import os
    import signal
    import subprocess
    import sys
    import time

    pytest.importorskip("distributed")
    case = TINY_CASE.replace("stop_time = 0.02", "stop_time = 50.0")  # minutes: stopped by Ctrl-C
    sweep = write_sweep(tmp_path, LONG_SWEEP, case)
    out = tmp_path / "out"
    cmd = [sys.executable, "-c", "import sys; from granflow.cli import main; sys.exit(main(sys.argv[1:]))",
           "sweep", str(sweep), "--out", str(out), "--workers", "2"]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
                            start_new_session=True, preexec_fn=terminal_sigint)
    deadline = time.monotonic() + 120.0
    while (len(list(out.glob("m000*/progress.json"))) < 2 and time.monotonic() < deadline
           and proc.poll() is None):
        time.sleep(0.2)  # wait until both workers run a member (on a loaded machine one starts late)
    assert len(list(out.glob("m000*/progress.json"))) == 2, (
        "the two members did not start", proc.poll(), proc.stderr.read() if proc.poll() is not None else "")
    sent = time.monotonic()
    os.killpg(proc.pid, signal.SIGINT)
    try:
        _, err = proc.communicate(timeout=60.0)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    took = time.monotonic() - sent
    assert proc.returncode == 130, err
    assert "Traceback" not in err and "still alive" not in err and "CancelledError" not in err, err
    assert took < 30.0, took
    assert "granflow: sweep interrupted (Ctrl-C): 0 of 3 member(s) done" in err
    assert "run the same command again" in err
    stopped = [json.loads(p.read_text())["error"] for p in out.glob("m000*/error.json")]
    assert not list(out.glob("m000*/summary.json"))
    assert len(stopped) == 2 and all("the sweep was stopped" in e for e in stopped)  # the running two
    queued = [d for d in out.glob("m000*") if not (d / "error.json").exists()]
    assert len(queued) == 1 and sorted(p.name for p in queued[0].iterdir()) == ["member.json"]  # not started


def test_sweep_display_on_a_terminal_without_rich_rewrites_one_line(monkeypatch):
    """Without rich (not a dependency), a terminal gets the running line rewritten in place every
    report (it printed one every 10 s), the finished members' lines kept above it."""
    import io
    import sys as _sys

    from granflow.cli.sweep import ERASE_LINE, SweepDisplay
    from granflow.sweep import SweepProgress

    monkeypatch.setitem(_sys.modules, "rich", None)  # import rich -> ImportError
    monkeypatch.setitem(_sys.modules, "rich.console", None)
    stream = io.StringIO()
    display = SweepDisplay(stream, tty=True)
    running = {"m0000": {"t": 0.1, "stop_time": 0.5}}
    display(SweepProgress(None, None, 0, 2, 1.0, running, {}))
    display(SweepProgress(None, None, 0, 2, 2.0, {"m0000": {"t": 0.2, "stop_time": 0.5}}, {}))
    display(SweepProgress("m0000", "ok", 1, 2, 3.0, {}, {"runout_m": 0.1}))
    display(SweepProgress("m0001", "ok", 2, 2, 4.0, {}, {"runout_m": 0.2}))
    display.close()
    text = stream.getvalue()
    assert text.count("\n") == 2  # only the finished members' lines stay
    frames = [f.replace(ERASE_LINE, "") for f in text.split("\r") if f.replace(ERASE_LINE, "")]
    assert frames == ["granflow: sweep: 0/2 done, 0:00:01 elapsed; running: m0000 t = 0.1/0.5",
                      "granflow: sweep: 0/2 done, 0:00:02 elapsed; running: m0000 t = 0.2/0.5",
                      "granflow: sweep: m0000 ok (1/2 done, 0:00:03 elapsed): run-out 0.1 m\n",
                      "granflow: sweep: 1/2 done, 0:00:03 elapsed; starting the next member(s)",
                      "granflow: sweep: m0001 ok (2/2 done, 0:00:04 elapsed): run-out 0.2 m\n"]


def test_sweep_display_with_rich(monkeypatch):
    """The rich branch (rich is optional and not installed in CI) against a stand-in with the
    rich API it uses: a bar per member (its simulated time, "compiling kernels, once" while it
    compiles), the overall bar, the finished member's line printed above the bars."""
    import io
    import sys as _sys
    import types
    from types import SimpleNamespace

    from granflow.cli.sweep import SweepDisplay
    from granflow.sweep import SweepProgress

    printed, state = [], {"started": False, "stopped": False}

    class Progress:
        def __init__(self, console=None, transient=False):
            self.console, self.tasks = console, []

        def add_task(self, description, total=None):
            self.tasks.append(SimpleNamespace(id=len(self.tasks), description=description, total=total,
                                              completed=0.0))
            return self.tasks[-1].id

        def update(self, task, **kw):
            for k, v in kw.items():
                setattr(self.tasks[task], k, v)

        def start(self):
            state["started"] = True

        def stop(self):
            state["stopped"] = True

    class Console:
        def __init__(self, file=None):
            self.file = file

        def print(self, text, **kw):
            printed.append(text)

    rich = types.ModuleType("rich")
    monkeypatch.setitem(_sys.modules, "rich", rich)
    monkeypatch.setitem(_sys.modules, "rich.console", SimpleNamespace(Console=Console))
    monkeypatch.setitem(_sys.modules, "rich.progress", SimpleNamespace(Progress=Progress))
    display = SweepDisplay(io.StringIO(), tty=True)
    bars = display._rich.tasks
    display(SweepProgress(None, None, 0, 2, 1.0, {"m0000": {"t": 0.0, "stop_time": 0.5, "warming_up": True}}, {}))
    assert bars[1].description == "m0000 (compiling kernels, once)" and bars[1].total == 0.5
    display(SweepProgress(None, None, 0, 2, 2.0, {"m0000": {"t": 0.25, "stop_time": 0.5}}, {}))
    assert bars[1].description == "m0000" and bars[1].completed == 0.25
    display(SweepProgress("m0000", "ok", 1, 2, 3.0, {}, {"runout_m": 0.1}))
    assert bars[1].completed == 0.5 and bars[1].description == "m0000 ok"
    assert bars[0].completed == 1 and bars[0].total == 2
    assert printed == ["granflow: sweep: m0000 ok (1/2 done, 0:00:03 elapsed): run-out 0.1 m"]
    display.close()
    assert state == {"started": True, "stopped": True}
