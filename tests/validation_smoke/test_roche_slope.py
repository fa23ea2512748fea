"""Roche's channel on a slope (issue 13 item 3e; validation/roche/slope.py): the ratio table on
synthetic rows with known answers, and the ``--quick`` runs at 10 deg against the flat channel
(tilting the channel forward lengthens both run-outs: gravity's downslope component
g sin(theta) adds to the drive; the mass-quantile fronts lie behind the thickness front)."""
from __future__ import annotations

import pytest

from _scripts import load_script


@pytest.fixture(scope="module")
def slope():
    return load_script("validation/roche/slope.py", "roche_slope", cached=True)


def _row(state: str, slope: float, runout: float, x99: float, contact=None) -> dict:
    return {"state": state, "slope_deg": slope, "runout_rest_m": runout, "wall_contact": contact or {},
            "t_rest_s": 1.0, "x_quantile_beyond_gate_m": {"0.5": x99 / 3, "0.9": x99 / 2, "0.99": x99}}


def test_ratios_of_synthetic_rows(slope):
    rows = [_row("fluidised", 0.0, 1.2, 1.0), _row("dry", 0.0, 0.8, 0.5),
            _row("fluidised", 10.0, 1.5, 1.2, {"east_wall": 0.9}), _row("dry", 10.0, 1.0, 0.6)]
    r = slope.ratios(rows)
    assert [e["slope_deg"] for e in r] == [0.0, 10.0]
    assert r[0]["ratio_runout"] == pytest.approx(1.5) and r[0]["ratio_x0.99"] == pytest.approx(2.0)
    assert r[0]["cut"] is False and r[1]["cut"] is True
    assert "reached the end" in slope.table(rows).splitlines()[-1]


def test_quick_runs_on_a_slope_spread_further_than_on_the_flat(slope, capsys):
    """``main(["--quick"])`` (the smoke run of tests/validation_smoke/test_validation_smoke.py)."""
    out = slope.main(["--quick"])
    assert "| 10 |" in capsys.readouterr().out
    rows = {(r["slope_deg"], r["state"]): r for r in out}
    for st in ("fluidised", "dry"):
        flat, tilted = rows[(0.0, st)], rows[(10.0, st)]
        assert not flat["wall_contact"] and not tilted["wall_contact"]
        assert tilted["runout_rest_m"] > flat["runout_rest_m"] + 0.04
        q = tilted["x_quantile_beyond_gate_m"]
        assert 0 < q["0.5"] < q["0.9"] < q["0.99"] <= tilted["runout_rest_m"] + 0.04
