"""granflow against Basilisk, side by side on the same machine (issue 15 item 1).

Case: Basilisk's public ``granular_column.c`` (sandbox/M1EMN/Exemples, with its header
``granular.h``; Lagree, Staron & Popinet 2011) and granflow's matching ``lagree_column`` case
(examples/lagree_column.toml), aspect ratio ``--aspect`` (default 1.42), n x n cells on the 5 x 5
box (Basilisk's ``N = 1 << LEVEL``), to t = 4. granflow runs as its command line does
(``granflow run examples/lagree_column.toml --set grid.nx=n --set grid.nz=n --set
time.stop_time=4 ...``) once per ``--variants`` entry (:data:`VARIANTS`): ``defaults`` (the case
file's numerics), ``v2`` (scheme v2 with the converged Picard loop, the defaults of sessions
12-24, pinned), ``v1`` and ``consistent`` (the threshold surface, pinned), and the one-solve
variants (the tables of benchmarks/README.md measured before v2 became the default call v1
"default"; those measured before session 25 call today's ``v2`` "defaults").
No figures, NetCDF records every
1 time unit (t = 0..4, like the original's output times), one BLAS/OpenMP thread.

Basilisk is not part of this repository and nothing here builds it: ``--basilisk-dir`` names a
folder outside the repository holding a built executable ``granular_column_bench`` (at its top or
in ``case/``), a variant of granular_column.c made and compiled by the user as benchmarks/README.md
describes in words. Its interface: ``granular_column_bench LEVEL ASPECT`` runs one aspect ratio to
t = 4 with the original's physics, time-step control and event times (its output events emptied,
so that the dt sequence is unchanged), and prints at t = 1, 2, 3, 4 one line
``deposit t i dx h_0 ... h_{N-1}`` (``i`` the step count, ``h`` = VOF fraction summed over each
column times dz). Without that folder or that executable the script prints why and exits 0.

Timing: whole processes, ``--pairs`` rounds per resolution, each round running every code once
with the order rotated between rounds (the machine may be shared: alternating spreads the
load over all codes). Per run: wall time (``time.perf_counter``) and user CPU time
(``resource.getrusage(RUSAGE_CHILDREN)`` delta, which includes granflow's interpreter start-up,
imports and set-up; the table also gives granflow's in-run wall time, summary.json's ``wall_s``,
without them). The table gives medians over the rounds, the ratios granflow / Basilisk of those
medians, and cell-steps per user-CPU second (n^2 x accepted steps / user s). One untimed warm-up
run of each granflow variant (16^2, a few steps) fills Numba's cache first, after granflow's
``__pycache__`` is written (startup.compile_bytecode: an installed package has its bytecode; with
``PYTHONDONTWRITEBYTECODE`` set and none written, every run compiled granflow's sources again,
0.1-0.2 s of user CPU on the 2-core development machine; tables before 2026-12-06 session 22 were
measured so). Asserts nothing about time.

Same deposit rule on both codes: h(x) = sum_z phi dz / phi_max per column (Basilisk: the VOF
fraction), front = right edge of the last column with h > 0.05 H0. The script prints the fronts
at t = 1..4 of both codes and Basilisk's h(x) at t = 4 at x = 0, 0.25, ..., 3.5 (linear between
column centres, as granflow's ``final_profile``).

Run:   python benchmarks/vs_basilisk.py --basilisk-dir /path/outside/the/repo
       python benchmarks/vs_basilisk.py --basilisk-dir DIR --resolutions 64,128,256 --pairs 3
       python benchmarks/vs_basilisk.py --quick [--basilisk-dir DIR]   # one round at 64^2, the defaults only
Time:  one round ~1 min at 64^2, ~2-3 min at 128^2, ~8-10 min at 256^2 (two granflow variants;
       2-core machine, another job running).
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from granflow.config.overrides import CONVERGED_LOOP

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))
from startup import CLI, compile_bytecode, cpu_model  # noqa: E402  (shared with startup.py)

CASE_FILE = ROOT / "examples" / "lagree_column.toml"
EXECUTABLE = "granular_column_bench"
"""Name of the user-built Basilisk variant (benchmarks/README.md, "granflow against Basilisk")."""
STOP_TIME = 4.0
TIMES = (1.0, 2.0, 3.0, 4.0)
FRONT_THRESHOLD = 0.05
"""Deposit thickness defining the front [H0] on both codes."""
PROFILE_X = tuple(np.round(np.arange(0.0, 3.5 + 1e-9, 0.25), 2))
"""Stations of Basilisk's h(x) at t = 4 [H0]."""
LOOP = list(CONVERGED_LOOP)
"""The converged Picard loop, the defaults until session 25 (2026-12-06)."""
ONE_SOLVE = ["numerics.picard.max_sweeps=1", "numerics.picard.predictor=extrapolated"]
VARIANTS = {
    "defaults": [],
    "v1": ["numerics.advection=upwind", "numerics.surface=threshold", *LOOP],
    "consistent": ["numerics.advection=consistent", "numerics.surface=threshold", *LOOP],
    "v2": LOOP,
    "v2_cfl04": [*LOOP, "time.cfl=0.4"],
    "v2_1solve": [*ONE_SOLVE, "time.cfl=0.3", "numerics.ambient.velocity_band_margin=0"],
    "v2_1solve_cfl04": [*ONE_SOLVE, "time.cfl=0.4", "numerics.ambient.velocity_band_margin=0"],
    "v2_1solve_cfl04_keep": [*ONE_SOLVE, "time.cfl=0.4", "numerics.ambient.velocity_band_margin=3"],
}
"""granflow's numerics per variant (``--set`` overrides on top of the case file). ``defaults``
is the case file's numerics as they stand; every other variant pins its options so that it keeps
its meaning when the defaults change: ``v2`` is scheme v2 with the converged Picard loop (up to
10 sweeps, first iterate u^n, CFL 0.3, the pattern rebuilt every step: the defaults until session
25), ``v1`` and ``consistent`` the same loop with the threshold surface (and upwind momentum for
v1); ``v2_cfl04`` changes only CFL-bound steps (256^2 and finer here, benchmarks/README.md);
``v2_1solve`` is the linearly implicit step, one solve per step with the coefficients of the
extrapolated first iterate, as Basilisk's step lags its viscosity by one step (docs/solver.md,
"One solve per step"); ``_keep`` adds the velocity band margin that keeps the pattern and
PARDISO's analysis across steps (docs/solver.md, "Keeping the pattern").
``v2_1solve_cfl04_keep`` equals ``defaults`` since session 25."""
COMMON_SETS = ["time.stop_at_rest=100", "output.figures=false", "output.interval=1"]
"""Run to stop_time (the pile does not rest for 100 time units before t = 4), no figures,
records at t = 0, 1, .., 4."""
ENV = {"OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}


@dataclass
class Run:
    wall_s: float
    user_s: float
    steps: int
    fronts: list
    profile: list = field(default_factory=list)
    inner_s: float = float("nan")
    """granflow: the run's own wall time (summary.json ``wall_s``: no start-up, imports, set-up)."""


def level_of(n: int) -> int:
    lev = n.bit_length() - 1
    if n <= 0 or 1 << lev != n:
        raise SystemExit(f"resolution {n}: Basilisk's multigrid needs a power of two")
    return lev


def find_executable(basilisk_dir: Path | None) -> tuple[Path | None, str]:
    """The Basilisk variant's executable in ``basilisk_dir`` (or ``basilisk_dir/case``), or None
    and the reason."""
    if basilisk_dir is None:
        return None, "no --basilisk-dir given"
    if not basilisk_dir.is_dir():
        return None, f"{basilisk_dir} is not a directory"
    for cand in (basilisk_dir / EXECUTABLE, basilisk_dir / "case" / EXECUTABLE):
        if cand.is_file() and os.access(cand, os.X_OK):
            return cand, ""
    return None, (f"no executable {EXECUTABLE} in {basilisk_dir} or {basilisk_dir / 'case'} "
                  "(build it as benchmarks/README.md describes)")


def timed(cmd: list[str], **kw) -> tuple[subprocess.CompletedProcess, float, float]:
    """Run ``cmd`` to completion; (result, wall s, user CPU s of the child and its children)."""
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    res = subprocess.run(cmd, capture_output=True, text=True, **kw)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if res.returncode != 0:
        raise RuntimeError(f"{' '.join(map(str, cmd))} exited {res.returncode}:\n{res.stderr[-2000:]}")
    return res, wall, r1.ru_utime - r0.ru_utime


def parse_deposits(text: str) -> dict[float, tuple[int, float, np.ndarray]]:
    """``deposit t i dx h_0 ... h_{N-1}`` lines -> {t: (steps, dx, h)}."""
    out = {}
    for line in text.splitlines():
        w = line.split()
        if w and w[0] == "deposit":
            out[float(w[1])] = (int(w[2]), float(w[3]), np.array([float(v) for v in w[4:]]))
    return out


def front(h: np.ndarray, dx: float, threshold: float = FRONT_THRESHOLD) -> float:
    """Right edge of the last column with h > threshold (nan if none): granflow's rule
    (granflow.diagnostics.front_from_thickness, "edge"), columns of width dx from x = 0."""
    idx = np.flatnonzero(h > threshold)
    return float((idx[-1] + 1) * dx) if idx.size else float("nan")


def profile(h: np.ndarray, dx: float, x=PROFILE_X) -> list[float]:
    """h at ``x``, linear between column centres (constant beyond the first and last centre)."""
    xc = (np.arange(h.size) + 0.5) * dx
    return [float(v) for v in np.interp(x, xc, h)]


def run_basilisk(exe: Path, n: int, aspect: float) -> Run:
    res, wall, user = timed([str(exe), str(level_of(n)), f"{aspect:g}"], cwd=exe.parent)
    dep = parse_deposits(res.stdout)
    missing = [t for t in TIMES if t not in dep]
    if missing:
        raise RuntimeError(f"{exe}: no deposit line at t = {missing} (is it the variant benchmarks/README.md describes?)")
    steps, dx, h4 = dep[STOP_TIME]
    return Run(wall, user, steps, [front(dep[t][2], dep[t][1]) for t in TIMES], profile(h4, dx))


def granflow_cmd(n: int, aspect: float, variant: str, out: Path, stop_time: float = STOP_TIME) -> list[str]:
    sets = [f"grid.nx={n}", f"grid.nz={n}", f"time.stop_time={stop_time:g}", f"setup.a={aspect:g}",
            *COMMON_SETS, *VARIANTS[variant]]
    cmd = [sys.executable, "-c", CLI, "run", str(CASE_FILE), "--out", str(out)]
    for s in sets:
        cmd += ["--set", s]
    return cmd


def run_granflow(n: int, aspect: float, variant: str, tmp: Path, tag: str) -> Run:
    out = tmp / f"{variant}_{n}_{tag}"
    _, wall, user = timed(granflow_cmd(n, aspect, variant, out), cwd=ROOT, env={**os.environ, **ENV})
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    fa = summary["case_diagnostics"]["front_at"]
    fronts = [fa.get(f"{t:g}") for t in TIMES]
    return Run(wall, user, int(summary["steps"]), [float("nan") if f is None else f for f in fronts],
               summary["case_diagnostics"]["final_profile"]["h"], inner_s=float(summary["wall_s"]))


WARM_UP_ASPECT = 1.42
"""Aspect ratio of the warm-up runs (at 16^2 a = 6.26's column would be narrower than a cell)."""


def warm_up(variants: list[str], tmp: Path) -> None:
    """granflow's bytecode written, then one untimed short run of each variant (Numba compiles
    its kernels into the cache once)."""
    print(compile_bytecode())
    for v in variants:
        out = tmp / f"warmup_{v}"
        timed(granflow_cmd(16, WARM_UP_ASPECT, v, out, stop_time=0.05), cwd=ROOT, env={**os.environ, **ENV})


def fmt(x: float, spec: str = ".3f") -> str:
    if x is None or (isinstance(x, float) and np.isnan(x)):
        return "–"
    return format(x + 0.0 if abs(x) >= 5e-4 else 0.0, spec)  # no "-0.000" for round-off


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--basilisk-dir", type=Path, default=None,
                    help="folder outside the repository with the built granular_column_bench")
    ap.add_argument("--resolutions", default="64,128", help="n of the n x n grids (powers of two)")
    ap.add_argument("--pairs", type=int, default=3, help="timed rounds per resolution (default 3)")
    ap.add_argument("--pairs-at", default="",
                    help="rounds for some resolutions, e.g. 256:1 (overrides --pairs there)")
    ap.add_argument("--aspect", type=float, default=1.42, help="aspect ratio a = H0/L0 (0.5, 1.42, 6.26)")
    ap.add_argument("--variants", default="defaults,v2",
                    help=f"granflow numerics, any of {','.join(VARIANTS)} (default: defaults,v2)")
    ap.add_argument("--quick", action="store_true", help="one round at 64^2, the default numerics only")
    args = ap.parse_args(argv)

    exe, why = find_executable(args.basilisk_dir)
    if exe is None:
        print(f"vs_basilisk: skipped: {why}. Basilisk is not part of granflow; see "
              "benchmarks/README.md for how to build the case outside the repository.")
        return 0
    variants = args.variants.split(",")
    bad = [v for v in variants if v not in VARIANTS]
    if bad:
        ap.error(f"unknown variants {bad}; choose from {list(VARIANTS)}")
    resolutions = [int(r) for r in args.resolutions.split(",")]
    pairs_at = {int(k): int(v) for k, v in (p.split(":") for p in args.pairs_at.split(",") if p)}
    if args.quick:
        resolutions, variants, pairs_at = [64], ["defaults"], {64: 1}
    for n in resolutions:
        level_of(n)

    codes = ["basilisk", *variants]
    print(f"CPU: {cpu_model()} ({os.cpu_count()} logical cores), Python {sys.version.split()[0]}, "
          f"load average at start {os.getloadavg()[0]:.2f}")
    print(f"Basilisk: {exe}; granflow: {CASE_FILE.relative_to(ROOT)}, a = {args.aspect:g}, to t = {STOP_TIME:g}, "
          f"variants {', '.join(variants)}; medians of whole-process times, order rotated per round")
    runs: dict[tuple[int, str], list[Run]] = {}
    with tempfile.TemporaryDirectory(prefix="vs_basilisk_") as tmpdir:
        tmp = Path(tmpdir)
        warm_up(variants, tmp)
        for n in resolutions:
            k = pairs_at.get(n, args.pairs)
            for r in range(k):
                order = codes[r % len(codes):] + codes[:r % len(codes)]
                for code in order:
                    run = (run_basilisk(exe, n, args.aspect) if code == "basilisk"
                           else run_granflow(n, args.aspect, code, tmp, str(r)))
                    runs.setdefault((n, code), []).append(run)
                    print(f"  {n}^2 round {r + 1}/{k} {code}: wall {run.wall_s:.2f} s, user {run.user_s:.2f} s, "
                          f"{run.steps} steps, front t=4 {fmt(run.fronts[-1])}", flush=True)

    print()
    print("| grid | granflow variant | rounds | granflow wall s | granflow user s | granflow in-run wall s "
          "| Basilisk wall s | Basilisk user s | wall ratio | user ratio | steps gf / B "
          "| cell·steps per CPU s gf / B | front t=4 gf / B |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---|---|")
    for n in resolutions:
        b = runs[(n, "basilisk")]
        bw, bu = statistics.median(x.wall_s for x in b), statistics.median(x.user_s for x in b)
        for v in variants:
            g = runs[(n, v)]
            gw, gu = statistics.median(x.wall_s for x in g), statistics.median(x.user_s for x in g)
            cs_g, cs_b = n * n * g[0].steps / gu, n * n * b[0].steps / bu
            gi = statistics.median(x.inner_s for x in g)
            print(f"| {n}² | {v} | {len(g)} | {gw:.2f} | {gu:.2f} | {gi:.2f} | {bw:.2f} | {bu:.2f} | {gw / bw:.2f} "
                  f"| {gu / bu:.2f} | {g[0].steps} / {b[0].steps} | {cs_g:.2e} / {cs_b:.2e} "
                  f"| {fmt(g[0].fronts[-1])} / {fmt(b[0].fronts[-1])} |")
    print()
    print(f"Fronts at t = 1, 2, 3, 4 (h > {FRONT_THRESHOLD} H0, right column edge), a = {args.aspect:g}:")
    for n in resolutions:
        for code in codes:
            print(f"  {n}^2 {code:10s} " + ", ".join(fmt(f) for f in runs[(n, code)][0].fronts))
    print(f"Basilisk h(x) at t = 4, x = {PROFILE_X[0]:g}, {PROFILE_X[1]:g}, ..., {PROFILE_X[-1]:g}:")
    for n in resolutions:
        print(f"  {n}^2 " + " ".join(fmt(h) for h in runs[(n, 'basilisk')][0].profile))
    print("h(x) at t = 4, x = 0, 0.5, ..., 3.5 (granflow's final_profile stations):")
    for n in resolutions:
        for code in codes:
            prof = runs[(n, code)][0].profile
            prof = prof[::2] if code == "basilisk" else prof  # Basilisk's stations are every 0.25
            print(f"  {n}^2 {code:10s} " + " ".join(fmt(h) for h in prof))
    return 0


if __name__ == "__main__":
    sys.exit(main())
