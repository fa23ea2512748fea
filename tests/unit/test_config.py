"""Case files (granflow.config) through ``granflow run`` / ``granflow config show``.

Every malformed input must end with exit code 2, ONE line on stderr naming the offending key path,
no traceback, and nothing computed (the output directory is not even created). Expected key paths
and phrases below are written from the case-file format, not taken from the code's output.
"""
from __future__ import annotations

import json
import re
import tomllib
from pathlib import Path

import pytest
from pydantic import ValidationError

from granflow.cases import CASES
from granflow.cases.options import describe_options
from granflow.cli import ExitCode, main
from granflow.config import MAX_CELLS, CaseConfig, load_case
from granflow.errors import GranflowInputError
from _scripts import ROOT  # the repository (tests/ holds tiers)

BASE = """\
[case]
name = "column_collapse"

[setup]
H0 = 0.1
L0 = 0.1

[closure]
name = "drucker_prager"
delta_deg = 26.74

[grid]
nx = 16
nz = 6
Lx = 0.4
Lz = 0.15

[time]
stop_time = 0.01
"""


def _replace(old: str, new: str) -> str:
    assert old in BASE
    return BASE.replace(old, new)


#: (id, case-file text or bytes, extra --set items, phrases that must appear in the message)
MALFORMED = [
    ("unknown_key", _replace("nz = 6", "nz = 6\nnxx = 3"), [], ["grid.nxx", "unknown key", "nx"]),
    ("unknown_section", BASE + "\n[gird]\nnx = 3\n", [], ["gird", "unknown key"]),
    ("string_for_int", _replace("nx = 16", 'nx = "16"'), [], ["grid.nx", "integer"]),
    ("float_for_int", _replace("nx = 16", "nx = 16.0"), [], ["grid.nx", "integer"]),
    ("bool_for_float", BASE, ["material.d=true"], ["material.d", "number"]),
    ("nan", _replace("Lx = 0.4", "Lx = nan"), [], ["grid.Lx", "finite"]),
    ("inf_closure_param", _replace("delta_deg = 26.74", "delta_deg = inf"), [], ["closure.delta_deg", "finite"]),
    ("negative_size", _replace("Lz = 0.15", "Lz = -0.15"), [], ["grid.Lz", "greater than 0"]),
    ("negative_diameter", BASE, ["material.d=-1e-4"], ["material.d", "greater than 0"]),
    ("too_few_cells", BASE, ["grid.nx=0"], ["grid.nx", "greater than or equal to 2"]),
    ("phi0_above_phi_max", BASE, ["setup.phi0=0.65"], ["setup.phi0", "phi_max"]),
    ("unknown_closure", _replace('name = "drucker_prager"', 'name = "mu_j"'), [], ["closure.name", "mu_j", "mu_i"]),
    ("unknown_closure_param", _replace("delta_deg = 26.74", "delta_dg = 26.74"), [], ["closure.delta_dg", "delta_deg"]),
    ("closure_param_type", _replace("delta_deg = 26.74", 'delta_deg = "30"'), [], ["closure.delta_deg", "number"]),
    ("closure_param_range", _replace("delta_deg = 26.74", "delta_deg = -5.0"), [], ["closure.delta_deg"]),
    ("huge_grid", BASE, ["grid.nx=10000", "grid.nz=10000"], ["grid", str(MAX_CELLS)]),
    ("toml_syntax", _replace("[grid]", "[grid\n"), [], ["TOML", "line 12", "column 6"]),
    ("not_utf8", b"[case]\nname = \"column_collapse\"\n\xff\xfe\x00garbage", [], ["UTF-8", "line 3"]),
    ("unicode_bare_key", BASE + "\n\u2603\u202e = 1\n", [], ["TOML", "line"]),
    ("unicode_quoted_key", BASE + '\n[output]\n"fi\\u00eblds\\nx" = 1\n', [], ["output.", "unknown key"]),
    ("missing_case", BASE.replace('[case]\nname = "column_collapse"\n', ""), [], ["case", "missing"]),
    ("unknown_case", _replace('name = "column_collapse"', 'name = "column"'), [], ["case.name", "column_collapse"]),
    ("cfl_above_half", BASE, ["time.cfl=0.9"], ["time.cfl", "0.5"]),
    ("zero_stop_time", BASE, ["time.stop_time=0"], ["time.stop_time"]),
    ("column_too_tall", BASE, ["setup.H0=1.0"], ["setup.H0", "grid.Lz"]),
    ("unknown_equilibrium", BASE + '\n[equilibrium]\nlaw = "nope"\n', [], ["equilibrium.law", "linear"]),
    ("unknown_output_field", BASE + '\n[output]\nfields = ["phi", "q"]\n', [], ["output.fields", "q"]),
    ("section_is_scalar", BASE.replace("[time]\nstop_time = 0.01\n", "time = 3\n"), [], ["time"]),
    ("bad_set_syntax", BASE, ["grid.nx"], ["--set", "grid.nx"]),
    ("b0_without_gas", BASE, ["setup.b0=0.5"], ["setup.b0"]),
    ("closure_material", BASE, ["closure.material=1"], ["closure.material", "[material]"]),
]


def _write(tmp_path: Path, content) -> Path:
    path = tmp_path / "case.toml"
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content, encoding="utf-8")
    return path


@pytest.mark.parametrize("content, sets, phrases", [m[1:] for m in MALFORMED], ids=[m[0] for m in MALFORMED])
def test_malformed_case_file_exits_2_with_one_line_naming_the_key(tmp_path, capsys, content, sets, phrases):
    path = _write(tmp_path, content)
    out = tmp_path / "out"
    argv = ["run", str(path), "--out", str(out), "--quiet"]
    for item in sets:
        argv += ["--set", item]
    code = main(argv)
    stdout, stderr = capsys.readouterr()
    assert code == ExitCode.BAD_INPUT, stderr
    assert stdout == ""
    lines = stderr.strip("\n").split("\n")
    assert len(lines) == 1, stderr
    assert lines[0].startswith("granflow: error: ")
    assert "Traceback" not in stderr
    for phrase in phrases:
        assert phrase in lines[0], (phrase, lines[0])
    assert not out.exists()  # nothing computed, nothing written


def test_several_errors_are_reported_in_one_message(tmp_path):
    path = _write(tmp_path, BASE)
    with pytest.raises(GranflowInputError) as info:
        load_case(path, ["grid.nx=0", "material.d=-1.0", "closure.delta_dg=3", "time.cfl=0.9"])
    msg = str(info.value)
    assert "\n" not in msg
    for key in ("grid.nx", "material.d", "closure.delta_dg", "time.cfl"):
        assert key in msg


def test_overrides_are_toml_values(tmp_path):
    path = _write(tmp_path, _replace("delta_deg = 26.74", ""))
    cfg = load_case(path, ["grid.nx=20", 'closure.name="mu_i"', "closure.mu1=0.4",
                           'output.fields=["phi", "p"]', "numerics.picard.max_sweeps=6",
                           "walls.west=no_slip"])
    assert cfg.grid.nx == 20 and isinstance(cfg.grid.nx, int)
    assert cfg.closure.name == "mu_i" and cfg.make_closure().mu1 == 0.4
    assert cfg.output.fields == ["phi", "p"]
    assert cfg.numerics.picard.max_sweeps == 6
    assert cfg.walls.west == "no_slip"  # a bare word is a string
    assert cfg.overrides[0] == "grid.nx=20"
    assert cfg.source_text == path.read_text()


def test_defaults_fill_a_minimal_file_and_the_config_is_frozen(tmp_path):
    cfg = load_case(_write(tmp_path, '[case]\nname = "static_layer"\n'))
    assert cfg.case.name == "static_layer" and cfg.setup.H == 0.05
    with pytest.raises(ValidationError):
        cfg.grid.nx = 3  # frozen


def test_effective_toml_round_trips(tmp_path):
    cfg = load_case(_write(tmp_path, BASE), ["closure.delta_deg=30.0"])
    again = CaseConfig.from_dict(tomllib.loads(cfg.to_toml()))
    assert again.model_dump() == cfg.model_dump()
    assert again.make_closure().delta_deg == 30.0


def test_gravity_vector_of_a_slope(tmp_path):
    import math

    cfg = load_case(_write(tmp_path, BASE), ["gravity.slope_deg=30.0", "gravity.g=10.0"])
    gx, gz = cfg.gravity_vector
    assert gx == pytest.approx(5.0, rel=1e-14) and gz == pytest.approx(-10.0 * math.sqrt(3) / 2, rel=1e-14)


@pytest.mark.parametrize("case", CASES.names())
def test_every_option_has_units_and_config_show_lists_it(case, capsys):
    options = describe_options(case)
    for key, opt in options.items():
        assert re.search(r"\[[^\]]+\]", opt["description"]), (key, opt["description"])  # "[unit]"
    for section in ("material.d", "grid.nx", "time.stop_time", "numerics.picard.max_sweeps",
                    "output.interval", "closure.name", "closure.delta_deg"):
        assert section in options
    assert main(["config", "show", case]) == ExitCode.OK
    out = capsys.readouterr().out
    for key in options:
        head, _, leaf = key.rpartition(".")
        assert f"[{head}]" in out and f"\n{leaf} = " in out, key


def test_config_show_of_a_file_shows_its_values(tmp_path, capsys):
    path = _write(tmp_path, BASE)
    assert main(["config", "show", str(path), "--set", "grid.nx=33", "--json"]) == ExitCode.OK
    import json

    data = json.loads(capsys.readouterr().out)
    assert data["grid.nx"]["value"] == 33 and data["grid.nx"]["default"] == 40
    assert data["closure.delta_deg"]["value"] == 26.74


def test_list_cases(capsys):
    assert main(["list", "cases"]) == ExitCode.OK
    out = capsys.readouterr().out
    for name in CASES.names():
        assert name in out


def test_docs_page_lists_every_case_and_option():
    doc = (ROOT / "docs" / "cases.md").read_text()
    for case in CASES.names():
        assert f"## `{case}`" in doc
        for key in describe_options(case):
            assert f"`{key}`" in doc, key
    for code in ("| 0 |", "| 1 |", "| 2 |", "| 3 |", "| 130 |"):
        assert code in doc


OPTION_ROW = re.compile(r"^\| `([a-z_]+\.[a-zA-Z0-9_.]+)` \| ([^|]*?) \|", re.M)


def _documented_default(text: str):
    """A default as docs/cases.md writes it: a JSON literal, or None for "(unset...)", "(none)",
    "None" and a default taken from another option (e.g. ``material.phi_max``)."""
    if text == "None" or text.startswith("(") or re.fullmatch(r"[a-z_]+\.[a-z_.]+", text):
        return None
    return json.loads(text)


def _same(documented, default) -> bool:
    if isinstance(default, float) and not isinstance(documented, bool | str | None | list):
        return documented == pytest.approx(default, rel=1e-12)
    return documented == default


def test_docs_page_states_every_default_as_the_schema_does():
    """The defaults column of docs/cases.md against the case schemas (describe_options): a
    changed default (e.g. the loop's of session 25) must change its row. A key shared by several
    cases must have the same default in all of them or be documented per case."""
    rows = OPTION_ROW.findall((ROOT / "docs" / "cases.md").read_text())
    assert len(rows) > 100  # the tables are found
    wrong = []
    for key, text in rows:
        documented = _documented_default(text.strip())
        defaults = [describe_options(c)[key]["default"] for c in CASES.names() if key in describe_options(c)]
        if not any(_same(documented, d) for d in defaults):
            wrong.append((key, text, defaults))
    assert wrong == []


def test_option_names_come_from_the_model_enums_and_solvers_are_registered():
    """The numerics and gas Literals are derived from the enums the Model takes (one list of names),
    every solver a case may name other than "auto" is in the solver registry, and the defaults of
    [time] and [numerics] are the Model's and the Simulation's."""
    import typing

    from granflow import simulation
    from granflow.config.schema import GasSection, NumericsSection, PicardSection, TimeSection, enum_values
    from granflow.model_options import Predictor
    from granflow.gas import GasLaw
    from granflow.model import AUTO_BANDED_DIRECT_UNKNOWNS, DEFAULT_EPS, LinearSolverChoice, Surface
    from granflow.physics.momentum import Advection
    from granflow.solvers import LINEAR_SOLVERS

    def options(model, key):
        return typing.get_args(model.model_fields[key].annotation)

    assert options(NumericsSection, "linear_solver") == enum_values(LinearSolverChoice)
    assert options(NumericsSection, "advection") == enum_values(Advection)
    assert options(NumericsSection, "surface") == enum_values(Surface)
    assert options(GasSection, "law") == enum_values(GasLaw)
    assert options(PicardSection, "predictor") == enum_values(Predictor)
    assert set(enum_values(LinearSolverChoice)) - {LinearSolverChoice.AUTO.value} <= set(LINEAR_SOLVERS.names())
    t = TimeSection()
    assert (t.cfl, t.dt_max, t.max_retries) == (simulation.DEFAULT_CFL, simulation.DEFAULT_DT_MAX,
                                                simulation.DEFAULT_MAX_RETRIES)
    assert NumericsSection().eps == DEFAULT_EPS
    assert f"{AUTO_BANDED_DIRECT_UNKNOWNS} unknowns" in NumericsSection.model_fields["linear_solver"].description


@pytest.mark.parametrize(("sets", "advised"), [
    (['numerics.surface="threshold"'], True),
    (['numerics.surface="threshold"', "numerics.picard.max_sweeps=10"], False),
    (["numerics.picard.max_sweeps=1"], False),
])
def test_the_threshold_surface_with_one_solve_is_advised_against(sets, advised):
    """granflow.config.checks.advisories: the threshold surface with one solve per step (the
    default since session 25) runs, with a warning that names both options and the converged loop's
    settings; with the loop, or with the indicator surface, nothing is advised."""
    from granflow.config.checks import advisories

    got = advisories(load_case(ROOT / "examples" / "inclined_layer.toml", sets))
    assert len(got) == advised
    if advised:
        assert "numerics.surface" in got[0] and "numerics.picard.max_sweeps=10" in got[0]
