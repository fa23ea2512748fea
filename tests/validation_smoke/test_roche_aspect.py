"""Roche's channel at other aspect ratios (issue 13 item 3a; validation/roche/aspect.py): the ratio
table on synthetic rows with known answers, and ``main(["--quick"])`` at a = 1 (4 cm cells, 0.4 s):
the fluidised column's bulk is ahead of the dry one's (its basal friction is carried by the gas),
both clear of the channel's end."""
from __future__ import annotations

import json

import pytest

from _scripts import load_script


@pytest.fixture(scope="module")
def aspect():
    return load_script("validation/roche/aspect.py", "roche_aspect", cached=True)


def _row(state, a, dx, runout, x9, x99, rest=1.0, dt_max=2.5e-4):
    return {"state": state, "a": a, "dx_m": dx, "L0_m": 0.4 / a, "runout_rest_m": runout, "t_rest_s": rest,
            "wall_contact": {}, "beyond_gate_m": {"0.5": x9 / 2, "0.9": x9, "0.99": x99}, "dt_max_s": dt_max}


def test_ratios_of_synthetic_rows(aspect):
    rows = [_row("fluidised", 1.0, 0.02, 2.0, 1.2, 1.8), _row("dry", 1.0, 0.02, 1.0, 0.6, 1.2),
            _row("fluidised", 1.0, 0.01, 1.8, 1.1, 1.7, rest=None), _row("dry", 1.0, 0.01, 1.2, 0.55, 1.1)]
    r = {e["dx_m"]: e for e in aspect.ratios(rows)}
    assert r[0.02]["runout"] == pytest.approx(2.0) and r[0.02]["x0.9"] == pytest.approx(2.0)
    assert r[0.02]["x0.99"] == pytest.approx(1.5) and not r[0.02]["moving"] and r[0.01]["moving"]
    assert "still moving" in aspect.table(rows)


def test_quick_run(aspect, capsys):
    rows = {r["state"]: r for r in aspect.main(["--quick"])}
    assert "| 1 | 4 |" in capsys.readouterr().out
    f, d = rows["fluidised"], rows["dry"]
    assert not f["wall_contact"] and not d["wall_contact"]
    assert f["beyond_gate_m"]["0.9"] > d["beyond_gate_m"]["0.9"] > 0


def test_whole_cells(aspect):
    """The gate is a cell face: L0 = 0.1 m on 4 cm cells is skipped, on 5 mm cells it is 20 cells."""
    assert aspect.whole_cells(0.1, 0.005) and aspect.whole_cells(0.8, 0.01) and aspect.whole_cells(0.4, 0.04)
    assert not aspect.whole_cells(0.1, 0.04) and not aspect.whole_cells(0.01, 0.02)


def test_converged_uses_the_three_finest_levels(aspect):
    """x_0.9 ratios 2.4, 2.2, 2.1 on 4, 2, 1 cm (first order towards 2.0, dry fixed): the 3-level
    Richardson estimate is 2.0; a coarser fourth level is left out."""
    rows = []
    for dx, x9 in ((0.08, 9.0), (0.04, 2.4), (0.02, 2.2), (0.01, 2.1)):
        rows += [_row("fluidised", 1.0, dx, 1.5, x9, 1.8), _row("dry", 1.0, dx, 1.0, 1.0, 1.2)]
    (c,) = aspect.converged(rows)
    assert c["dx_m"] == [0.04, 0.02, 0.01] and c["x0.9"]["method"] == "3-level Richardson"
    assert c["x0.9"]["value"] == pytest.approx(2.0) and c["x0.9"]["order"] == pytest.approx(1.0)
    assert c["runout"]["value"] == pytest.approx(1.5) and "| 1 | 4, 2, 1 |" in aspect.converged_table(rows)


def test_several_aspects_in_one_call_store_each_row_once(aspect, monkeypatch, tmp_path):
    """Regression: ``main(["--aspects", "1,2"])`` stored the second aspect's rows twice (the merged
    list, which already held the stored row of a = 2, was extended by the new one)."""
    store = tmp_path / "aspect.json"
    stored = [_row(s, a, 0.02, 0.5, 0.3, 0.4) for a in (1.0, 2.0, 4.0) for s in ("fluidised", "dry")]
    store.write_text(json.dumps({"rows": stored}))
    monkeypatch.setattr(aspect, "ASPECT_JSON", store)
    monkeypatch.setattr(aspect, "run", lambda dx, quick, aspects: [
        _row(s, aspects[0], dx, 2.0, 1.2, 1.8) for s in ("fluidised", "dry")])
    aspect.main(["--aspects", "1,2", "--dx", "0.02"])
    rows = json.loads(store.read_text())["rows"]
    keys = [(r["a"], r["dx_m"], r["state"]) for r in rows]
    assert len(keys) == len(set(keys)) == 6
    assert {r["a"]: r["runout_rest_m"] for r in rows} == {1.0: 2.0, 2.0: 2.0, 4.0: 0.5}


def test_stored_rows_at_another_time_step_are_dropped(aspect, monkeypatch, tmp_path):
    """A stored row at another dt_max (or recording none: the 1 ms rows of sessions 20-25) is not
    merged with rows at :data:`DT_MAX`: a table mixing time steps is no convergence study."""
    assert aspect.DT_MAX == 2.5e-4  # the rows of _row
    store = tmp_path / "aspect.json"
    old = _row("dry", 2.0, 0.01, 0.5, 0.3, 0.4)
    del old["dt_max_s"]
    stored = [_row("dry", 1.0, 0.01, 0.5, 0.3, 0.4, dt_max=1e-3), old, _row("dry", 4.0, 0.01, 0.5, 0.3, 0.4)]
    store.write_text(json.dumps({"rows": stored}))
    monkeypatch.setattr(aspect, "ASPECT_JSON", store)
    rows = aspect.merged([_row("fluidised", 1.0, 0.02, 2.0, 1.2, 1.8)])
    assert [(r["a"], r["dx_m"]) for r in rows] == [(1.0, 0.02), (4.0, 0.01)]
