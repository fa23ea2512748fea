"""Figure smoke tests (issue 16 item 9): every figure granflow writes -- the run figures of every
example, the verification cases' reference figures, ``granflow plot``, ``granflow check --plot``
and ``granflow stability dispersion --plot`` -- passes :func:`_figure_checks.figure_problems`
(axis labels, tick labels that do not overlap, data within the limits, no clipped text), and the
checks themselves catch the faults the issue reported."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from granflow.cli import ExitCode, main
from granflow.config import load_case

from _figure_checks import figure_problems  # noqa: E402  (tests/, on sys.path: tests/conftest.py)

from _scripts import ROOT  # noqa: E402  (the repository; tests/ holds tiers)
EXAMPLES = ROOT / "examples"
SMALL = {  # per case: a grid and a duration that keep each run to a few seconds
    "column_collapse": ["grid.nx=24", "grid.nz=9", "time.stop_time=0.15"],
    "lagree_column": ["grid.nx=16", "grid.nz=16", "time.stop_time=1.0"],
    "inclined_layer": ["time.stop_time=2.0"],
    "defluidisation_column": ["time.stop_time=0.05"],
    "sheared_layer": ["time.stop_time=5e-4"],
    "static_layer": ["time.stop_time=0.01"],
}
SMALL_BY_EXAMPLE = {  # examples whose box does not fit the case's small grid: L0 a whole number of cells
    "roche_channel": ["grid.nx=32", "grid.nz=9", "time.stop_time=0.15", "setup.prep_max_time=0.05"],
    "roche_channel_dry": ["grid.nx=32", "grid.nz=9", "time.stop_time=0.15"],
}


@pytest.fixture
def saved(monkeypatch) -> dict:
    """The Figure objects granflow saves, by file name."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    figures = {}
    original = Figure.savefig

    def keep(self, path, *args, **kwargs):
        figures[Path(path).name] = self
        return original(self, path, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", keep)
    return figures


def case_examples() -> list[Path]:
    return [p for p in sorted(EXAMPLES.glob("*.toml")) if "[case]" in p.read_text()]


def test_every_case_has_small_settings():
    assert {load_case(p).case.name for p in case_examples()} == set(SMALL)


@pytest.mark.parametrize("path", case_examples(), ids=lambda p: p.stem)
def test_the_figures_of_every_example_pass_the_referee_checks(path, tmp_path, saved, capsys):
    argv = ["run", str(path), "--out", str(tmp_path / "run"), "--quiet"]
    for item in SMALL_BY_EXAMPLE.get(path.stem, SMALL[load_case(path).case.name]):
        argv += ["--set", item]
    assert main(argv) == ExitCode.OK, capsys.readouterr().err
    assert "snapshots.png" in saved
    for name, fig in saved.items():
        assert figure_problems(fig, name) == []
    if load_case(path).case.name in ("defluidisation_column", "inclined_layer", "sheared_layer", "static_layer"):
        assert set(saved) & {"basal_pressure.png", "profile.png", "relaxation.png", "pressure.png"}


def test_plot_check_and_dispersion_figures_pass(tmp_path, saved, capsys):
    run_dir = tmp_path / "d"
    assert main(["run", str(EXAMPLES / "defluidisation_column.toml"), "--out", str(run_dir), "--quiet",
                 "--set", "time.stop_time=0.02", "--set", "output.figures=false"]) == ExitCode.OK
    for var in ("phi", "p_f", "speed"):
        assert main(["plot", str(run_dir), "--var", var, "--out", str(tmp_path / f"{var}.png")]) == ExitCode.OK
    assert main(["check", "roux_radjai", "--plot", str(tmp_path / "check.png")]) == ExitCode.OK
    assert main(["stability", "dispersion", "roux_radjai", "--plot", str(tmp_path / "rr.png")]) == ExitCode.OK
    capsys.readouterr()
    assert set(saved) == {"phi.png", "p_f.png", "speed.png", "check.png", "rr.png"}
    for name, fig in saved.items():
        assert figure_problems(fig, name) == []


# --------------------------------------------------------------------------- the checks can fail
def _narrow_column(edges_from_centres: bool):
    """The defluidisation column's snapshot panel: 3 x 12 cells of 1 cm, to scale, in a narrow
    panel; the mesh from the cell centres (matplotlib's edges start at 8.7e-19) or exact edges."""
    from granflow import plotting

    plt = plotting._pyplot()
    x, z = (np.arange(3) + 0.5) * 0.01, (np.arange(12) + 0.5) * 0.01
    fig, ax = plt.subplots(figsize=(2.4, 3.0), constrained_layout=True)
    if edges_from_centres:
        ax.pcolormesh(x, z, np.ones((12, 3)), shading="auto")
    else:
        from granflow.output.vtk import cell_edges

        ax.pcolormesh(cell_edges(x), cell_edges(z), np.ones((12, 3)))
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("z [m]")
    return plt, fig, ax


def test_overlapping_tick_labels_are_caught_and_thinned():
    from granflow.figure_layout import thin_ticks

    plt, fig, ax = _narrow_column(edges_from_centres=True)
    problems = figure_problems(fig)
    assert any("tick labels '0.00' and '0.01' overlap" in p for p in problems), problems
    assert ax.get_xlim()[0] != 0.0  # the round-off edge that crowds the locator
    thin_ticks(fig)
    assert figure_problems(fig) == []
    plt.close(fig)
    plt, fig, ax = _narrow_column(edges_from_centres=False)
    assert ax.get_xlim()[0] == 0.0
    thin_ticks(fig)
    assert figure_problems(fig) == []
    plt.close(fig)


def test_missing_labels_data_outside_limits_and_clipped_text_are_caught():
    from granflow import plotting

    plt = plotting._pyplot()
    fig, ax = plt.subplots(figsize=(4, 3))
    ax.plot([0.0, 1.0, 2.0], [0.0, 1.0, 5.0], label="data")
    ax.set_ylim(0.0, 2.0)
    ax.set_title("a title far too long to fit in a small figure of four inches " * 2)
    problems = figure_problems(fig)
    assert any("no x label" in p for p in problems) and any("no y label" in p for p in problems)
    assert any("line 'data' leaves the limits" in p for p in problems)
    assert any("is clipped" in p for p in problems)
    plt.close(fig)


def test_mesh_edges_start_at_zero(tmp_path):
    import xarray as xr

    from granflow import plotting

    ds = xr.Dataset(coords={"x": (np.arange(3) + 0.5) * 0.01, "z": (np.arange(12) + 0.5) * 0.01})
    xe, ze = plotting.mesh_xz(ds)
    assert xe[0] == 0.0 and ze[0] == 0.0 and xe.size == 4 and ze.size == 13
    np.testing.assert_allclose(ze[-1], 0.12, rtol=1e-12)


# --------------------------------------------------------------------------- front.png
def _series(x_front, ke):
    import xarray as xr

    t = np.arange(len(ke)) * 0.1
    ds = xr.Dataset({"x_front": ("time", np.asarray(x_front, dtype=float)),
                     "kinetic_energy": ("time", np.asarray(ke, dtype=float))},
                    coords={"time": t, "x": np.array([0.5, 1.5]) * 0.01})
    ds["x"].attrs["units"] = "m"
    ds["time"].attrs["units"] = "s"
    return ds


def test_front_figure_draws_what_moves_and_says_what_does_not(tmp_path, saved):
    from granflow import plotting

    at_rest = [0.0, 1e-31, 1e-30, 1e-30]
    assert plotting.front_figure(_series([0.06] * 4, at_rest), tmp_path / "a.png") is None  # static layer
    assert not (tmp_path / "a.png").exists()

    plotting.front_figure(_series([0.1, 0.1, 0.1, 0.1], [0.0, 0.3, 0.5, 0.4]), tmp_path / "b.png")
    front_ax, ke_ax = saved["b.png"].axes  # a collapse before its front moves: drawn, flat
    assert front_ax.get_ylabel() == "front position [m]" and ke_ax.get_yscale() == "linear"

    plotting.front_figure(_series([0.1, 0.2, 0.3, 0.3], at_rest), tmp_path / "c.png")
    ke_ax = saved["c.png"].axes[1]
    assert ke_ax.get_lines() == [] and any(t.get_gid() == "at_rest" for t in ke_ax.texts)

    ke = [0.0, 1.0, 1e-2, 1e-6]  # release to rest: log axis, the zero at release not drawn
    plotting.front_figure(_series([0.1, 0.2, 0.3, 0.3], ke), tmp_path / "d.png")
    line = saved["d.png"].axes[1].get_lines()[0]
    assert saved["d.png"].axes[1].get_yscale() == "log" and np.isnan(line.get_ydata()[0])

    plotting.front_figure(_series([np.nan] * 4, [0.5, 0.52, 0.53, 0.53]), tmp_path / "e.png")
    (ax,) = saved["e.png"].axes  # a periodic layer: the energy on the main axis, a note
    assert ax.get_ylabel() == "kinetic energy [J m-1]" and any(t.get_gid() == "no_front" for t in ax.texts)
    for name, fig in saved.items():
        assert figure_problems(fig, name) == []
