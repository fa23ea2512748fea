"""What limits the injected bed's gain (issue 13; validation/roche/limits.py): the ratio table on
synthetic rows with known answers, and ``main(["--quick"])`` (4 cm cells, 0.4 s): with the gas
supply kept under the reservoir the fluidised bulk runs further than with it stopped, and both
further than the dry one's."""
from __future__ import annotations

import pytest

from _scripts import load_script


@pytest.fixture(scope="module")
def limits():
    return load_script("validation/roche/limits.py", "roche_limits", cached=True)


def _row(variant, runout, x9, rest=1.0, walls=None):
    return {"variant": variant, "state": "dry" if variant == "dry" else "fluidised", "runout_rest_m": runout,
            "t_rest_s": rest, "wall_contact": walls or {}, "beyond_gate_m": {"0.9": x9}}


def test_ratios_of_synthetic_rows(limits):
    rows = [_row("dry", 1.0, 0.5), _row("protocol", 1.4, 0.8), _row("supply_base", 3.0, 2.0, walls={"east": 1.2})]
    r = {e["variant"]: e for e in limits.ratios(rows)}
    assert r["protocol"]["runout"] == pytest.approx(1.4) and r["protocol"]["x0.9"] == pytest.approx(1.6)
    assert not r["protocol"]["bounded"] and r["supply_base"]["bounded"]
    assert "reached the end (ratios: lower bounds)" in limits.table(rows)


def test_every_variant_sets_a_known_option(limits):
    from granflow.config import load_case

    for name, sets in limits.VARIANTS.items():
        load_case(limits.channel.CHANNEL_FILES["fluidised"], list(sets))  # raises on an unknown key or value


def test_quick_run(limits, capsys):
    rows = {r["variant"]: r for r in limits.main(["--quick"])}
    assert "| supply_reservoir |" in capsys.readouterr().out
    dry, stopped, kept = (rows[k]["beyond_gate_m"]["0.9"] for k in ("dry", "protocol", "supply_reservoir"))
    assert kept > stopped > dry > 0
