"""Smoke runs of the validation/figure scripts at their coarsest size, so they cannot rot.

Every validation script has one shape (issue 18 item 5; granflow.verification.scripts): ``run(resolution,
quick=False)`` and ``main(argv)`` with ``--quick``; each ``--quick`` runs here (seconds) and writes
nothing into the repository.
"""
from __future__ import annotations

import inspect
from pathlib import Path

import pytest

from _scripts import load_script

from _scripts import ROOT  # noqa: E402  (the repository; tests/ holds tiers)


def _load(rel: str):
    return load_script(rel)


SCRIPTS = sorted(p.relative_to(ROOT).as_posix() for p in (ROOT / "validation").glob("*/*.py"))
"""Every validation script (validation/*/run.py, fluidised_vs_dry/convergence.py, theory/make_figures.py)."""
QUICK_TESTED_ELSEWHERE = {"validation/basilisk_column/run.py": "test_basilisk_column_quick_and_comparison_rule",
                          "validation/theory/make_figures.py": "test_theory_figures_quick",
                          "validation/roche/slope.py": "test_roche_slope.py::test_quick_runs_on_a_slope_spread_further_than_on_the_flat",
                          "validation/roche/aspect.py": "test_roche_aspect.py::test_quick_run",
                          "validation/roche/limits.py": "test_roche_limits.py::test_quick_run",
                          "validation/roche/defluidisation.py": "test_roche_defluidisation.py",
                          "validation/topography/run.py": "test_validation_topography.py",
                          "validation/axisymmetric/run.py": "test_validation_axisymmetric.py"}


def test_the_script_list_is_complete():
    assert len(SCRIPTS) == 19 and "validation/fluidised_vs_dry/convergence.py" in SCRIPTS
    assert "validation/roche/run.py" in SCRIPTS and "validation/roche/slope.py" in SCRIPTS


@pytest.mark.parametrize("rel", SCRIPTS)
def test_every_validation_script_has_run_resolution_quick_and_main_argv(rel):
    mod = _load(rel)
    run = list(inspect.signature(mod.run).parameters.values())
    assert run[1].name == "quick" and run[1].default is False
    assert list(inspect.signature(mod.main).parameters) == ["argv"]
    assert "--quick" in inspect.getsource(mod.main)


def _files(folder: Path) -> dict[Path, int]:
    return {p: p.stat().st_mtime_ns for p in folder.rglob("*") if p.is_file() and "__pycache__" not in p.parts}


@pytest.mark.parametrize("rel", [r for r in SCRIPTS if r not in QUICK_TESTED_ELSEWHERE])
def test_quick_smoke_run_and_nothing_written_in_the_repository(rel, capsys):
    folder = (ROOT / rel).parent
    before = _files(folder)
    returned = _load(rel).main(["--quick"])
    printed = capsys.readouterr().out
    assert returned or printed.strip()
    assert _files(folder) == before


def test_theory_figures_quick(tmp_path):
    paths = _load("validation/theory/make_figures.py").run(tmp_path, quick=True)
    assert len(paths) == 4
    for p in paths:
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_basilisk_column_quick_and_comparison_rule():
    """validation/basilisk_column: the quick run, and the comparison against Basilisk's table
    (relative front differences at the same resolution, computed here by hand)."""
    mod = _load("validation/basilisk_column/run.py")
    out = mod.main(["--quick"])["quick"]
    assert out["steps"] == 20 and 0.9 < out["h0"] <= 1.0 + 1e-12
    # Basilisk at a = 0.5, 128^2 on the h > 0.05 rule: 2.383, 3.086, 3.594, 3.828; h(0) = 1.000
    fake = {"a": 0.5, "n": 128, "fronts": [2.5, 3.0, None, 3.828], "profile_h": [1.0] * 8, "h0": 1.0}
    cmp_ = mod.compare(fake)
    assert cmp_["front_rel"][0] == (2.5 - 2.383) / 2.383 and cmp_["front_rel"][2] is None
    assert cmp_["front_rel"][3] == 0.0 and cmp_["profile_diff"][0] == 0.0


def test_model_runs_with_the_sharp_transport_and_consistent_momentum():
    """Scheme v2 options on a tiny dry collapse: mass to round-off, bounds without clipping."""
    import numpy as np

    from granflow import diagnostics as dg
    from granflow.grid import Grid
    from granflow.model import Model
    from granflow.rheology import make_closure
    from granflow.simulation import Simulation

    g = Grid(nx=16, nz=6, Lx=0.16, Lz=0.06)
    model = Model(g, make_closure("drucker_prager"), advection="consistent", phi_transport="sharp")
    X, Z = g.cell_coords()
    phi0 = np.where((X < 0.04) & (Z < 0.04), 0.6, 0.0)
    sim = Simulation(model, model.initial_state(phi0), stop_time=0.1).run()
    m0 = dg.mass(g, phi0)
    assert abs(dg.mass(g, sim.state.phi) - m0) <= 1e-12 * m0
    assert sim.totals.clipped_mass == 0.0 and sim.totals.added_mass == 0.0
    assert sim.state.phi.min() >= 0.0 and sim.state.phi.max() <= 0.6
    assert dg.front_position(g, sim.state.phi, 0.6, g.dz) > 0.04
