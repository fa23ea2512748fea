"""Common numerics options reach the Model of every case (review findings of session 2)."""
from __future__ import annotations


import pytest

from granflow.cases.registry import CASES
from granflow.config import load_case
from granflow.errors import GranflowInputError
from _scripts import ROOT  # the repository (tests/ holds tiers)

EXAMPLES = ROOT / "examples"
OPTIONS = ["numerics.isochoric_interface=0", "numerics.gravity_blend_velocity=0.5",
           "numerics.ambient.eta_b=0.1", "numerics.linear_solver=amg"]


@pytest.mark.parametrize("example", ["lagree_column.toml", "column_collapse_dry.toml", "static_layer.toml"])
def test_numerics_options_reach_the_model(example):
    cfg = load_case(EXAMPLES / example, overrides=OPTIONS + ["grid.nx=8", "grid.nz=8"])
    model = CASES.get(cfg.case.name).setup(cfg).model
    assert model.isochoric_interface == 0
    assert model.gravity_blend_velocity == 0.5
    assert model.ambient.background_viscosity == 0.1 == model.background_viscosity
    assert model.linear_solver_name == "amg"


def test_column_collapse_rejects_a_periodic_grid():
    with pytest.raises(GranflowInputError, match="grid.periodic_x"):
        load_case(EXAMPLES / "column_collapse_dry.toml", overrides=["grid.periodic_x=true"])


def test_material_fraction_output_needs_the_indicator_surface():
    """output.fields = ["c"] with the threshold surface names the key (there is no c to write)."""
    from granflow.errors import GranflowInputError

    with pytest.raises(GranflowInputError, match="output.fields"):
        load_case(EXAMPLES / "column_collapse_dry.toml",
                  overrides=['numerics.surface="threshold"', 'output.fields=["phi", "c"]'])
    cfg = load_case(EXAMPLES / "column_collapse_dry.toml", overrides=['output.fields=["phi", "c"]'])
    assert cfg.output.fields == ["phi", "c"]
