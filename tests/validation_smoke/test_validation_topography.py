"""validation/topography/run.py --quick (issue 14 item 3, acceptance (a)): a heap on a uniform
slope, as a staircase profile under vertical gravity and as a flat base under tilted gravity, at
N = 8 cells per unit length to t = 1 (STYLE.md idiom 11: the validation cannot rot).

What the smoke run checks: both discretisations keep their grain mass to round-off, the heap moves
down the slope in both, and the two agree on the centre of mass's travel and on the rear and front
quantiles within the staircase's coarse-grid tolerance (measured at N = 8 with the session-25
defaults: travel 0.0860 against 0.0834, 3 %; the front s_99 2.3125 against 2.3356, 1 %; tolerance
15 % and 3 %)."""
from __future__ import annotations

import pytest
from _scripts import load_script


def test_quick_run_agrees_between_the_two_frames():
    out = load_script("validation/topography/run.py", "topography_run").main(["--quick"])
    runs = {r["frame"]: r for r in out["runs"]}
    for r in runs.values():
        assert r["mass_end"] == pytest.approx(r["mass0"], rel=1e-12)
        assert r["rows"][-1]["travel"] > 0.02
    tilted, stair = runs["tilted"]["rows"][-1], runs["staircase"]["rows"][-1]
    assert stair["travel"] == pytest.approx(tilted["travel"], rel=0.15)
    assert stair["s_99"] == pytest.approx(tilted["s_99"], rel=0.03)
    assert stair["s_01"] == pytest.approx(tilted["s_01"], rel=0.08)
    (b,) = out["runout"]   # (b): the example's column down the profile, 24 x 10 cells to 0.05 s
    assert abs(b["mass_rel_error"]) < 1e-12 and b["front_m"] > 0.1 and -0.2 < b["energy_residual_rel"] < 0.0
