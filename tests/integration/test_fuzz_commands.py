"""Fuzzed bad input across every command (issue 17): run, check, derive, stability, sweep, plot and
export, with the kinds of input that an independent corpus found to crash, hang, be accepted
silently or write before refusing. Each generated input must end with exit code 2, exactly one
line ``granflow: error: ...`` on stderr naming the key or path (the fragment expected is fixed by
the generator, not read back from the code), no traceback, and nothing written: every file of the
working directory and of the shared fixtures is the same before and after, and no new file or
directory appears.

:data:`N_FAST` inputs run in CI (in-process, well under 60 s on 2 cores); the ``slow`` variant
runs :data:`N_SLOW` more from another seed.
"""
from __future__ import annotations

import os
import random
import shutil
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from granflow.cli import main
from granflow.output import load_checkpoint, save_checkpoint

from _scripts import ROOT  # noqa: E402  (the repository; tests/ holds tiers)
EXAMPLE_TEXT = (ROOT / "examples" / "column_collapse_dry.toml").read_text()
TINY = ["--set", "grid.nx=10", "--set", "grid.nz=6", "--set", "time.stop_time=0.004",
        "--set", "output.interval=0.002", "--set", "output.figures=false", "--quiet"]
N_FAST = 420
N_SLOW = 3000
SEED_FAST = 20261201
SEED_SLOW = 17
RESERVED = ("granflow_version", "checkpoint_schema", "created")


@dataclass
class Ctx:
    """The shared fixtures (read only) and the input's own working directory."""

    shared: Path
    work: Path

    @property
    def run_dir(self) -> Path:
        return self.shared / "run"

    @property
    def checkpoint(self) -> Path:
        return sorted((self.run_dir / "checkpoints").glob("*.npz"))[-1]

    def case(self, text: str = EXAMPLE_TEXT, name: str = "case.toml") -> str:
        path = self.work / name
        path.write_text(text, encoding="utf-8")
        return str(path)

    def file(self, name: str = "FILE") -> str:
        path = self.work / name
        path.write_text("not a directory\n")
        return str(path)


#: An input: (kind, builder(ctx) -> (argv, expected fragment of the error line)).
Builder = Callable[[Ctx], tuple[list[str], str]]


def _deep(rng: random.Random) -> str:
    n = rng.choice([17, 40, 200, 499, 600, 1000])
    if rng.random() < 0.5:
        return "[" * n + "]" * n
    return "{a = " * n + "1" + "}" * n


def _huge_int(rng: random.Random) -> tuple[str, str]:
    """(text, why): more than 4300 digits, or beyond 64 bits."""
    if rng.random() < 0.5:
        return "9" * rng.randint(4301, 6000), "digits"
    return str(rng.randint(2**63, 10**rng.randint(20, 4000))), "digits"


def _bad_out(rng: random.Random, ctx: Ctx, suffix: str = "") -> str:
    return rng.choice([ctx.file(), ctx.file() + "/sub" + suffix, f"/proc/granflow_x{rng.randint(0, 99)}{suffix}",
                       "/dev/null", ""])


NUMERIC = [("material", "d"), ("material", "rho_s"), ("material", "delta_phi"), ("material", "phi_max"),
           ("grid", "Lx"), ("time", "dt_max"), ("setup", "H0"), ("closure", "delta_deg"),
           ("gravity", "g"), ("time", "stop_time")]
UNPHYSICAL = [("material.rho_s", [1e300, 1e6, 1.0, 1e-3]), ("gravity.g", [1e300, 1e4, 301.0]),
              ("material.eta_f", [1e300, 100.0, 1e-12]), ("material.p_atm", [1e300, 1e12, 0.5]),
              ("material.rho_f0", [1e300, 1e5, 1e-9]), ("material.d", [1e-9, 5e-7]),
              ("material.c_I", [1e300, 0.01, 50.0]), ("numerics.eps", [1e300, 1e5, 1e-12]),
              ("numerics.delta_p", [1e300, 1e7, 1e-12]), ("numerics.ambient.rho_a", [1e300, 1e5, 1e-8]),
              ("numerics.ambient.eta_a", [1e300, 1e5, 1e-12]), ("numerics.ambient.eta_b", [1e300, 1e5]),
              ("numerics.gravity_blend_velocity", [1e300, 1e4, 1e-15]), ("grid.Lx", [1e-300, 1e-9]),
              ("grid.Lz", [1e-300, 1e-9]), ("gas.U_inj", [1e300, 1e4])]
NEGATIVE_YIELD = ["-1 - I", "-0.1*I", "0.3 - 2*I", "-phi", "0.1 - I^2", "-(0.4 + 0.2*I)", "I - 1"]
NONFINITE = ["I/0", "1e308**2", "1/(I - I)", "10**400", "0*I + 1e400", "phi/0 + 1", "zoo", "oo + I",
             "sqrt(-1)", "exp(1000)", "E**1000*I", "pi**700 + I", "I**1e10", "(1 + I)**200", "0.4 + (-2)**0.5"]
ON_LINE_NONFINITE = ["exp(1000*I)", "1/I", "I**-1", "0.4 + 1/(I - 0.5)**2"]
"""Finite expressions whose value on the equilibrium line is not (run only: ``check`` reports it)."""
PHYSICS = ['gas.law="linear"', "material.rho_s=2600.0", 'walls.bottom="free_slip"', "gravity.slope_deg=5.0",
           "closure.delta_deg=30.0", "material.eta_f=2e-5", "setup.H0=0.09", "material.phi_max=0.61"]


def _checkpoint_edit(rng: random.Random) -> tuple[str, Callable]:
    def arr(name, index, value):
        def f(a, s, m):
            a[name].ravel()[index % a[name].size] = value
        return f

    def scal(name, value):
        def f(a, s, m):
            s[name] = value
        return f

    i = rng.randrange(10**6)
    return rng.choice([
        ("state.phi", arr("state.phi", i, np.nan)), ("state.phi", arr("state.phi", i, rng.uniform(0.61, 50))),
        ("state.phi", arr("state.phi", i, -rng.uniform(1e-3, 5))), ("state.vel", arr("state.vel", i, np.inf)),
        ("state.p", arr("state.p", i, -np.inf)), ("state.p_f", arr("state.p_f", i, np.nan)),
        ("state.t", scal("state.t", float("nan"))), ("state.t", scal("state.t", -1.0)),
        ("state.t", scal("state.t", float("inf"))), ("state.step", scal("state.step", -3)),
        ("state.t", scal("state.t", 10.0 ** rng.uniform(0, 300))),  # beyond stop_time (looped for ever)
        ("state.p", arr("state.p", i, -rng.uniform(1.0, 1e9))), ("state.c", arr("state.c", i, rng.uniform(1.01, 9))),
        ("state.c", arr("state.c", i, -rng.uniform(0.01, 9))),
        ("schedule.output", scal("schedule.output", rng.choice([float("nan"), -rng.uniform(1e-3, 1e300)]))),
        ("totals.clipped_mass", scal("totals.clipped_mass", rng.choice([float("nan"), float("inf")]))),
        ("case", lambda a, s, m: m.__setitem__("case", "sheared_layer")),
        ("grid", lambda a, s, m: m.__setitem__("grid", [11, 6, 0.4, 0.15])),
    ])


def inputs(rng: random.Random) -> Iterator[tuple[str, Builder]]:
    """Yield (kind, builder) forever; every kind of the issue's list, across all commands."""
    while True:
        kind = rng.choice(KINDS)
        yield kind, _builder(kind, random.Random(rng.random()))


KINDS = ["run_out", "run_output_directory", "run_checkpoints_file", "run_summary_dir", "run_runs_file",
         "run_deep_file", "run_deep_set", "run_huge_int_file", "run_huge_int_set", "run_text_number",
         "run_newline_set", "run_unphysical", "run_d_column", "run_negative_yield", "run_nonfinite_yield",
         "run_dt_budget", "run_memory", "run_restart_state", "run_restart_physics", "run_restart_missing",
         "check_section_set", "check_bad_set", "check_text_number", "check_plot", "check_expression",
         "derive_expression", "derive_bad_set", "dispersion_plot", "dispersion_bad_set", "sweep_out",
         "sweep_deep", "sweep_self_base", "sweep_foreign_json", "plot_out", "plot_animate",
         "plot_truncated", "export_out", "export_truncated", "stability_nonfinite",
         "run_long_name", "run_figure_dir", "run_checkpoint_entry_dir", "sweep_member_file",
         "run_output_interval", "run_int_caps", "sweep_too_many", "sweep_workers",
         "sweep_strict_types", "check_bool_number", "run_device_file", "run_fields_repeated",
         "run_deep_key", "sweep_deep_key", "run_restart_output", "dispersion_extreme",
         "run_time_floor", "run_prep_budget"]
INT_CAPS = [("time.max_steps", 10**7), ("time.max_retries", 50), ("numerics.picard.max_sweeps", 1000),
            ("numerics.ambient.velocity_band", 10**6)]
"""Integer options and the largest value each accepts (beyond: a hang, or an overflow)."""


def _builder(kind: str, rng: random.Random) -> Builder:  # noqa: C901 - one branch per kind
    def build(ctx: Ctx) -> tuple[list[str], str]:
        run = lambda case, *extra: ["run", case, "--out", str(ctx.work / "out"), *TINY, *extra]  # noqa: E731
        if kind == "run_out":
            out = _bad_out(rng, ctx)
            return ["run", ctx.case(), "--out", out, *TINY], "--out"
        if kind == "run_output_directory":
            text = EXAMPLE_TEXT + f'\ndirectory = "{ctx.file()}/x{rng.randint(0, 9)}"\n'
            return ["run", ctx.case(text), *TINY], "output.directory"
        if kind == "run_checkpoints_file":
            (ctx.work / "out").mkdir()
            (ctx.work / "out" / "checkpoints").write_text("x")
            return run(ctx.case()), "checkpoints"
        if kind == "run_summary_dir":
            name = rng.choice(["summary.json", "output.nc"])
            (ctx.work / "out" / name).mkdir(parents=True)
            return run(ctx.case(), "--overwrite"), name
        if kind == "run_long_name":  # a component longer than NAME_MAX (255 bytes on Linux)
            name = rng.choice("abxyz") * rng.randint(256, 400)
            head = rng.choice([["run", ctx.case(), "--out"], ["plot", str(ctx.run_dir), "--out"],
                               ["export", "vtk", str(ctx.run_dir), "--out"], ["check", "mu_i", "--plot"]])
            tail = TINY if head[0] == "run" else []
            return [*head, str(ctx.work / name / "x") if rng.random() < 0.5 else str(ctx.work / name), *tail], \
                "too long"
        if kind == "run_figure_dir":
            name = rng.choice(["snapshots.png", "front.png"])
            (ctx.work / "out" / name).mkdir(parents=True)
            return run(ctx.case(), "--overwrite", "--set", "output.figures=true"), name
        if kind == "run_checkpoint_entry_dir":
            entry = ctx.work / "out" / "checkpoints" / f"checkpoint_{rng.randint(0, 9):08d}.npz"
            entry.mkdir(parents=True)
            return run(ctx.case(), "--overwrite"), entry.name
        if kind == "run_runs_file":
            ctx.file("runs")
            return ["run", ctx.case(), *TINY], "runs"
        if kind == "run_deep_file":
            sec = rng.choice(["grid", "time", "output", "material"])
            text = EXAMPLE_TEXT.replace(f"[{sec}]", f"[{sec}]\nq{rng.randint(0, 99)} = {_deep(rng)}")
            return run(ctx.case(text)), "nested"
        if kind == "run_deep_set":
            key = rng.choice(["grid.nx", "material.d", "setup.H0", "time.dt_max"])
            return run(ctx.case(), "--set", f"{key}={_deep(rng)}"), f"--set {key}"
        if kind == "run_huge_int_file":
            key = rng.choice(["nx", "nz"])
            value, why = _huge_int(rng)
            return run(ctx.case(EXAMPLE_TEXT.replace(f"{key} = ", f"{key} = {value} #"))), key
        if kind == "run_huge_int_set":
            key = rng.choice(["grid.nx", "grid.nz", "time.max_steps", "output.checkpoint_interval"])
            value, why = _huge_int(rng)
            return run(ctx.case(), "--set", f"{key}={value}"), key
        if kind == "run_text_number":
            sec, key = rng.choice(NUMERIC)
            text = rng.choice(["0.2", "1e-3", "10", "-1", " 0.5"])
            return run(ctx.case(), "--set", f'{sec}.{key}="{text}"'), f"{sec}.{key}"
        if kind == "run_newline_set":
            key = rng.choice(["grid.nx=10", "material.d=1e-4", 'closure.name="mu_i"'])
            sep = rng.choice(["\n", "\r\n", "\r"])
            return run(ctx.case(), "--set", f"{key}{sep}grid.nz={rng.randint(2, 9)}"), "line break"
        if kind == "run_unphysical":
            key, values = rng.choice(UNPHYSICAL)
            return run(ctx.case(), "--set", f"{key}={rng.choice(values)!r}"), key
        if kind == "run_d_column":
            return run(ctx.case(), "--set", "case.allow_unphysical=true",
                       "--set", f"material.d={rng.uniform(0.1, 0.9)!r}"), "material.d"
        if kind in ("run_negative_yield", "run_nonfinite_yield"):
            expr = rng.choice(NEGATIVE_YIELD if kind == "run_negative_yield" else NONFINITE + ON_LINE_NONFINITE)
            text = EXAMPLE_TEXT.replace('name = "drucker_prager"', 'name = "generic"').replace(
                "delta_deg = 26.74", f'expression = "{expr}"')
            return run(ctx.case(text)), "closure.expression"
        if kind == "run_output_interval":
            return run(ctx.case(), "--set", f"output.interval={10.0 ** rng.uniform(-300, -8)!r}"), "output.interval"
        if kind == "run_int_caps":
            key, most = rng.choice(INT_CAPS)
            return run(ctx.case(), "--set", f"{key}={rng.randint(most + 1, 2**63 - 1)}"), key
        if kind == "run_restart_output":  # continue a run whose output.nc is not a whole granflow output
            out = ctx.work / "out"
            shutil.copytree(ctx.run_dir, out)
            nc = out / "output.nc"
            how = rng.choice(["truncate", "junk", "empty", "foreign"])
            if how == "truncate":
                os.truncate(nc, rng.randint(100, nc.stat().st_size - 1))
            elif how == "junk":
                nc.write_bytes(b"CDF\x02" + bytes(rng.randrange(256) for _ in range(rng.randint(0, 500))))
            elif how == "empty":
                nc.write_bytes(b"")
            else:
                import netCDF4
                nc.unlink()
                with netCDF4.Dataset(nc, "w", format="NETCDF3_64BIT_OFFSET") as ds:
                    ds.createDimension(rng.choice(["x", "a"]), 3)
            return ["run", ctx.case(), "--out", str(out), *TINY, "--set", "time.stop_time=0.008",
                    "--restart", str(out)], "output.nc"
        if kind == "run_time_floor":  # within time.max_steps, but 1/dt overflows the matrices
            return run(ctx.case(), "--set", "time.max_steps=3", "--set",
                       f"time.cfl={10.0 ** rng.uniform(-300, -4.5)!r}"), "time.cfl"
        if kind == "run_prep_budget":  # the injection preparation ignores time.max_steps
            text = (ROOT / "examples" / "column_collapse_injected.toml").read_text()
            return run(ctx.case(text), "--set", "time.max_steps=3", "--set",
                       f"time.dt_max={10.0 ** rng.uniform(-11.9, -7.5)!r}"), "prep_max_time"
        if kind == "run_deep_key":  # a dotted --set key of hundreds of parts (RecursionError)
            head = rng.choice(["closure", "equilibrium", "grid", "setup", "q"])
            key = head + ".a" * rng.randint(17, 3000)
            return run(ctx.case(), "--set", f"{key}={rng.choice(['1', '0.5', 'x'])}"), "parts"
        if kind == "run_fields_repeated":
            field = rng.choice(["phi", "u", "p", "S"])
            return run(ctx.case(), "--set", f'output.fields=["{field}", "w", "{field}"]'), "output.fields"
        if kind == "run_device_file":  # a case or sweep file that never ends
            return [rng.choice(["run", "sweep"]), "/dev/zero", "--out", str(ctx.work / "o")], "/dev/zero"
        if kind == "check_bool_number":
            key, closure = rng.choice([("mu1", "mu_i"), ("delta_deg", "drucker_prager"), ("material.d", "mu_i"),
                                       ("material.rho_s", "drucker_prager"), ("equilibrium.delta_phi", "mu_i")])
            return ["check", closure, "--set", f"{key}={rng.choice(['true', 'false'])}"], key.split(".")[-1]
        if kind == "run_dt_budget":
            dt = 10.0 ** rng.uniform(-300, -7.2)
            return run(ctx.case(), "--set", f"time.dt_max={dt!r}", "--set", "time.stop_time=1.5"), "time.dt_max"
        if kind == "run_memory":
            n = rng.randint(1000, 2000)
            return run(ctx.case(), "--set", f"grid.nx={n}", "--set", f"grid.nz={n}"), "grid"
        if kind == "run_restart_state":
            what, edit = _checkpoint_edit(rng)
            a, s, m = load_checkpoint(ctx.checkpoint)
            a = {k: v.copy() for k, v in a.items()}
            m = {k: v for k, v in m.items() if k not in RESERVED}
            edit(a, s, m)
            save_checkpoint(ctx.work / "bad.npz", a, s, m)
            return run(ctx.case(), "--restart", str(ctx.work / "bad.npz")), "--restart"
        if kind == "run_restart_physics":
            return run(ctx.case(), "--set", rng.choice(PHYSICS), "--restart", str(ctx.run_dir)), "other physics"
        if kind == "run_restart_missing":
            target = rng.choice(["none.npz", "empty_dir", "junk.npz"])
            if target == "empty_dir":
                (ctx.work / target).mkdir()
            elif target == "junk.npz":
                (ctx.work / target).write_bytes(bytes(rng.randrange(256) for _ in range(rng.randint(0, 300))))
            return run(ctx.case(), "--restart", str(ctx.work / target)), target
        if kind == "check_section_set":
            sec = rng.choice(["material", "equilibrium"])
            return ["check", rng.choice(["mu_i", "drucker_prager"]), "--set", f"{sec}={rng.randint(0, 9)}"], sec
        if kind in ("check_bad_set", "derive_bad_set", "dispersion_bad_set"):
            key = rng.choice(["material.d", "material.rho_s", "equilibrium.delta_phi"])
            value = rng.choice([_deep(rng), _huge_int(rng)[0], "1e-4\nmaterial.rho_s=3", "[" * 600])
            head = {"check_bad_set": ["check", "mu_i"], "derive_bad_set": ["derive", "0.4 + 0.2*I"],
                    "dispersion_bad_set": ["stability", "dispersion", "mu_i"]}[kind]
            return [*head, "--set", f"{key}={value}"], key
        if kind == "check_text_number":
            key, closure = rng.choice([("material.delta_phi", "mu_i"), ("material.d", "drucker_prager"),
                                       ("mu1", "mu_i"), ("delta_deg", "drucker_prager")])
            if rng.random() < 0.3:
                return ["check", "power_law", "--set", 'coefficients=["0.4", "0.2"]'], "coefficients"
            return ["check", closure, "--set", f'{key}="{rng.choice(["0.2", "0.3", "1"])}"'], key.split(".")[-1]
        if kind in ("check_plot", "dispersion_plot"):
            path = _bad_out(rng, ctx, ".png")
            if path == ctx.file():
                (ctx.work / "dir.png").mkdir()
                path = str(ctx.work / "dir.png")
            head = ["check", "mu_i"] if kind == "check_plot" else ["stability", "dispersion", "mu_i"]
            return [*head, "--plot", path], "--plot"
        if kind == "check_expression":
            return ["check", "generic", "--set", f'expression="{rng.choice(NONFINITE)}"'], "expression"
        if kind == "derive_expression":
            return ["derive", rng.choice(NONFINITE)], "yield function"
        if kind.startswith("sweep"):
            base = ctx.case()
            param = '[parameters]\n"setup.b0" = { values = [0.0] }\n'
            sweep = ctx.work / "sweep.toml"
            if kind == "sweep_self_base":
                sweep.write_text(f'[sweep]\nbase = "sweep.toml"\n{param}')
                return ["sweep", str(sweep), "--out", str(ctx.work / "sw")], "sweep.base"
            if kind == "sweep_deep":
                sweep.write_text(f'[sweep]\nbase = "{Path(base).name}"\n[parameters]\n'
                                 f'"setup.H0" = {{ values = {_deep(rng)} }}\n')
                return ["sweep", str(sweep), "--out", str(ctx.work / "sw")], "nested"
            sweep.write_text(f'[sweep]\nbase = "{Path(base).name}"\n{param}')
            if kind == "sweep_too_many":
                how = rng.choice(["range", "grid", "lhs"])
                if how == "range":
                    param = f'[parameters]\n"setup.H0" = {{ range = [0.05, 0.1], n = {rng.randint(10001, 10**9)} }}\n'
                elif how == "grid":
                    k = rng.randint(101, 300)
                    param = ("[parameters]\n" + f'"setup.H0" = {{ range = [0.05, 0.1], n = {k} }}\n'
                             + f'"setup.L0" = {{ range = [0.05, 0.1], n = {k} }}\n')
                else:
                    param = f'samples = {rng.randint(10001, 10**9)}\nseed = 1\n[parameters]\n"setup.H0" = {{ lhs = [0.05, 0.1] }}\n'
                    sweep.write_text(f'[sweep]\nbase = "{Path(base).name}"\nmode = "lhs"\n{param}')
                    return ["sweep", str(sweep), "--out", str(ctx.work / "sw")], "10000"
                sweep.write_text(f'[sweep]\nbase = "{Path(base).name}"\n{param}')
                return ["sweep", str(sweep), "--out", str(ctx.work / "sw")], "10000"
            if kind == "sweep_workers":
                n = 4 * (os.cpu_count() or 1) + rng.randint(1, 10**6)
                return ["sweep", str(sweep), "--out", str(ctx.work / "sw"), "--workers", str(n)], "--workers"
            if kind == "sweep_deep_key":
                key = rng.choice(["closure", "setup", "material"]) + ".a" * rng.randint(17, 3000)
                sweep.write_text(f'[sweep]\nbase = "{Path(base).name}"\n[parameters]\n"{key}" = {{ values = [1.0] }}\n')
                return ["sweep", str(sweep), "--out", str(ctx.work / "sw")], "parts"
            if kind == "sweep_strict_types":
                what = rng.choice(["n", "samples", "seed"])
                if what == "n":
                    value = rng.choice(["true", "2.0", "3.5", '"2"'])
                    param = f'[parameters]\n"setup.H0" = {{ range = [0.05, 0.1], n = {value} }}\n'
                    sweep.write_text(f'[sweep]\nbase = "{Path(base).name}"\n{param}')
                else:
                    value = rng.choice(["true", "2.0", f"-{rng.randint(1, 10**6)}"] if what == "seed"
                                       else ["true", "2.0", "0"])
                    other = "samples = 2" if what == "seed" else "seed = 1"
                    sweep.write_text(f'[sweep]\nbase = "{Path(base).name}"\nmode = "lhs"\n{what} = {value}\n'
                                     f'{other}\n[parameters]\n"setup.H0" = {{ lhs = [0.05, 0.1] }}\n')
                return ["sweep", str(sweep), "--out", str(ctx.work / "sw")], what
            if kind == "sweep_member_file":
                (ctx.work / "sw").mkdir()
                (ctx.work / "sw" / "m0000").write_text("a file")
                return ["sweep", str(sweep), "--out", str(ctx.work / "sw")], "m0000"
            if kind == "sweep_foreign_json":
                (ctx.work / "sw").mkdir()
                (ctx.work / "sw" / "sweep.json").write_text(rng.choice(["{}", "[1, 2]", "not json", '{"a": 1}']))
                return ["sweep", str(sweep), "--out", str(ctx.work / "sw")], "sweep.json"
            return ["sweep", str(sweep), "--out", _bad_out(rng, ctx)], "--out"
        if kind == "dispersion_extreme":  # finite options whose base state overflows (exit 3 before)
            extreme = rng.choice([["--p", "1e300"], ["--p", "1e-300"], ["--I", "1e-300"], ["--p-f", "1e300"],
                                  ["--phi", "1e-300"], ["--set", "material.rho_s=1e300"]])
            return ["stability", "dispersion", "mu_i", *extreme], "base state"
        if kind == "stability_nonfinite":
            bad = rng.choice(["inf", "-inf", "nan", "1e999"])
            if rng.random() < 0.5:
                values = {"mu1": "0.38", "mu2": "0.64", "I0": "0.3", "c-I": "2"}
                name = rng.choice(list(values))
                values[name] = bad
                return ["stability", "window", *[f"--{k}={v}" for k, v in values.items()]], f"--{name}"
            name = rng.choice(["p", "I", "p-f", "phi"])
            return ["stability", "dispersion", "mu_i", f"--{name}={bad}"], f"--{name}"
        if kind == "plot_out":
            return ["plot", str(ctx.run_dir), "--out", _bad_out(rng, ctx, ".png")], "--out"
        if kind == "plot_animate":
            return ["plot", str(ctx.run_dir), "--animate", _bad_out(rng, ctx, ".gif")], "--animate"
        if kind == "export_out":
            return ["export", "vtk", str(ctx.run_dir), "--out", _bad_out(rng, ctx)], "--out"
        if kind in ("plot_truncated", "export_truncated"):
            src = ctx.run_dir / "output.nc"
            run_dir = ctx.work / "trunc"
            run_dir.mkdir()
            dst = run_dir / "output.nc"
            shutil.copy(src, dst)
            os.truncate(dst, rng.randint(int(0.05 * src.stat().st_size), src.stat().st_size - 1))
            out = ["--out", str(ctx.work / ("p.png" if kind == "plot_truncated" else "vtk"))]
            head = ["plot"] if kind == "plot_truncated" else ["export", "vtk"]
            return [*head, str(run_dir), *out], "output.nc"
        raise AssertionError(kind)

    return build


def _corpus(seed: int, n: int) -> list[tuple[str, Builder]]:
    gen = inputs(random.Random(seed))
    return [next(gen) for _ in range(n)]


FAST = _corpus(SEED_FAST, N_FAST)


def _tree(root: Path) -> dict[str, tuple]:
    """Every entry under ``root``: files with size and mtime, directories by name only (a probe
    of writability may touch a directory's mtime, never its content)."""
    out = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for d in dirnames:
            out[os.path.relpath(os.path.join(dirpath, d), root)] = ("dir",)
        for f in filenames:
            st = os.stat(os.path.join(dirpath, f), follow_symlinks=False)
            out[os.path.relpath(os.path.join(dirpath, f), root)] = ("file", st.st_size, st.st_mtime_ns)
    return out


@pytest.fixture(scope="module")
def shared(tmp_path_factory) -> Path:
    """A finished tiny run (output.nc, checkpoints) that inputs read but must not change."""
    root = tmp_path_factory.mktemp("fuzz_shared")
    case = root / "case.toml"
    case.write_text(EXAMPLE_TEXT)
    assert main(["run", str(case), "--out", str(root / "run"), *TINY,
                 "--set", "output.checkpoint_interval=2"]) == 0
    return root


def _check(kind: str, build: Builder, shared: Path, work: Path, capsys, monkeypatch) -> None:
    from granflow.cases import memory

    monkeypatch.chdir(work)
    monkeypatch.setattr(memory, "available_memory", lambda: 2_000_000_000)  # 2 GB machine
    ctx = Ctx(shared, work)
    argv, needle = build(ctx)
    before, before_shared = _tree(work), _tree(shared)
    capsys.readouterr()
    code = main(argv)
    _, err = capsys.readouterr()
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert code == 2, (kind, argv[:6], err[-2000:])
    assert "Traceback" not in err, (kind, err)
    assert len(lines) == 1 and lines[0].startswith("granflow: error: "), (kind, err[-2000:])
    assert needle in lines[0], (kind, needle, lines[0][:500])
    assert _tree(work) == before, (kind, "wrote into the working directory", argv[:6])
    assert _tree(shared) == before_shared, (kind, "changed the shared run", argv[:6])


def test_corpus_covers_every_kind_and_command():
    kinds = {k for k, _ in FAST}
    assert len(FAST) >= 300
    assert kinds == set(KINDS), set(KINDS) - kinds
    assert {k.split("_")[0] for k in kinds} >= {"run", "check", "derive", "dispersion", "stability", "sweep",
                                                "plot", "export"}


@pytest.mark.parametrize("i", range(N_FAST))
def test_bad_input_exit_2_one_line_nothing_written(i, shared, tmp_path, capsys, monkeypatch):
    kind, build = FAST[i]
    _check(kind, build, shared, tmp_path, capsys, monkeypatch)


@pytest.mark.slow
def test_bad_input_large_corpus(shared, tmp_path, capsys, monkeypatch):
    for j, (kind, build) in enumerate(_corpus(SEED_SLOW, N_SLOW)):
        work = tmp_path / f"w{j}"
        work.mkdir()
        with monkeypatch.context() as mp:
            _check(kind, build, shared, work, capsys, mp)
