"""The command line: JSON shapes, readable output, and bad input -> exit 2 with one line, no traceback."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from granflow.cli import ExitCode, main


def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_list_closures_json_names_every_registered_closure(capsys):
    from granflow.rheology import CLOSURES

    code, out, _ = run(capsys, "list", "closures", "--json")
    assert code == ExitCode.OK
    data = json.loads(out)
    assert sorted(data) == CLOSURES.names()
    assert data["roux_radjai"]["reference"] is True
    assert data["drucker_prager"]["parameters"]["delta_deg"]["default"] == 25.0


def test_list_equilibria_text(capsys):
    code, out, _ = run(capsys, "list", "equilibria")
    assert code == ExitCode.OK
    for name in ("linear", "schaeffer", "robinson", "breard"):
        assert name in out


def test_check_json_shape(capsys):
    code, out, _ = run(capsys, "check", "drucker_prager", "--set", "delta_deg=30", "--json")
    assert code == ExitCode.OK
    data = json.loads(out)
    assert data["closure"] == "drucker_prager"
    assert data["parameters"]["delta_deg"] == 30.0
    expected = {"C1", "C2", "C2_strict", "C3", "dissipation", "equilibrium", "Z_nonnegative"}
    assert set(data["conditions"]) == expected
    for cond in data["conditions"].values():
        assert isinstance(cond["pass"], bool)
        assert isinstance(cond["fails_where"], list)
    # DP: dZ/dI = 0 so Barker's strict C2 fails while the paper's relaxed C2 holds.
    assert data["conditions"]["C2"]["pass"] and not data["conditions"]["C2_strict"]["pass"]


def test_check_strict_exit_code_reports_failure(capsys):
    code, _, _ = run(capsys, "check", "roux_radjai", "--strict")
    assert code == ExitCode.FAILED


def test_check_plot_writes_png(capsys, tmp_path):
    png = tmp_path / "dp.png"
    code, out, _ = run(capsys, "check", "drucker_prager_dilatancy", "--plot", str(png))
    assert code == ExitCode.OK
    assert png.stat().st_size > 10_000
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_window_json_matches_criterion(capsys):
    mu1, mu2, I0 = math.tan(math.radians(21)), math.tan(math.radians(33)), 0.3
    code, out, _ = run(capsys, "stability", "window", "--mu1", str(mu1), "--mu2", str(mu2), "--I0", "0.3", "--json")
    assert code == ExitCode.OK
    data = json.loads(out)
    lo, hi = data["I_low"], data["I_high"]
    assert 0 < lo < hi
    # Independent evaluation of Barker et al. (2015) at the end points: 4 nu^2 - 4 nu + mu^2 (1 - nu/2)^2 = 0.
    for I in (lo, hi):
        mu = mu1 + (mu2 - mu1) * I / (I + I0)
        nu = I * (mu2 - mu1) * I0 / (I + I0) ** 2 / mu
        assert abs(4 * nu**2 - 4 * nu + mu**2 * (1 - nu / 2) ** 2) < 1e-9


def test_dispersion_text_and_json(capsys):
    code, out, _ = run(capsys, "stability", "dispersion", "roux_radjai", "--I", "0.001", "--p", "1000", "--json")
    assert code == ExitCode.OK
    data = json.loads(out)
    assert data["leading_order"]["growth"] > 0  # Roux-Radjai (mu(I) yield, low I): unbounded growth at high k
    assert data["leading_order"]["well_posed"] is False
    code, out, _ = run(capsys, "stability", "dispersion", "mu_i", "--I", "0.01")
    assert code == ExitCode.OK
    assert "bounded growth" in out


def test_derive_reproduces_drucker_prager(capsys):
    code, out, _ = run(capsys, "derive", "1/2", "--json")
    assert code == ExitCode.OK
    data = json.loads(out)
    import sympy as sp

    I, Ieq = sp.symbols("I I_eq", positive=True)
    f = sp.sympify(data["f"], locals={"I": I, "I_eq": Ieq})
    assert sp.simplify(f - sp.Rational(1, 2) * (1 - Ieq / I)) == 0
    assert data["check"]["conditions"]["C1"]["pass"]


BAD_INPUTS = [
    (["check", "nope"], "nope"),
    (["check", "mu_i", "--set", "mu3=1"], "mu3"),
    (["check", "mu_i", "--set", "material.d=-1"], "material.d"),
    (["check", "mu_i", "--set", "mu1=0.9"], "mu2"),
    (["check", "mu_i", "--set", "delta_deg"], "delta_deg"),
    (["check", "drucker_prager", "--set", "delta_deg=95"], "delta_deg"),
    (["check", "mu_i", "--equilibrium", "quadratic"], "quadratic"),
    (["check", "mu_i", "--set", "foo.bar=1"], "foo.bar"),
    (["check", "power_law", "--set", "exponents=[-2]"], "exponents"),
    (["derive", "I^"], "I^"),
    (["derive", "I + x"], "x"),
    (["derive", "__import__('os')"], "forbidden"),
    (["stability", "window", "--mu1", "0.5", "--mu2", "0.4", "--I0", "0.3"], "mu2"),
    (["stability", "window", "--mu1", "abc", "--mu2", "0.4", "--I0", "0.3"], "abc"),
    (["stability", "dispersion", "mu_i", "--p", "-5"], "--p"),
    (["frobnicate"], "frobnicate"),
]


@pytest.mark.parametrize("argv,needle", BAD_INPUTS)
def test_bad_input_exit_2_one_line_no_traceback(capsys, argv, needle):
    code, out, err = run(capsys, *argv)
    assert code == ExitCode.BAD_INPUT, err
    assert "Traceback" not in err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, err
    assert needle in lines[0]


def test_version(capsys):
    code, out, _ = run(capsys, "--version")
    assert code == ExitCode.OK
    assert "granflow" in out


def test_overrides_parse_toml_values():
    from granflow.cli.overrides import parse_overrides

    ov = parse_overrides(["delta_deg=30", "material.d=1e-4", "exponents=[0, 1.5]", 'expression="I^2"', "yield_law=mu_i"])
    assert ov["closure"] == {"delta_deg": 30, "exponents": [0, 1.5], "expression": "I^2", "yield_law": "mu_i"}
    assert ov["material"] == {"d": 1e-4}
    assert np.isclose(ov["material"]["d"], 1e-4)
