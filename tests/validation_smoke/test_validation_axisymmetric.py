"""validation/axisymmetric/run.py --quick (issue 14 item 4): a dry cylinder of aspect ratio 1 on a
7-cell grid to t = 0.05 s through the case runner (STYLE.md idiom 11: the validation cannot rot).

What the smoke run checks: the cylinder's grain volume is kept to round-off, the column has started
to spread (its 99 % mass radius beyond R0), the energy error is small and negative (numerical
dissipation), and the three front definitions are ordered as they must be for a deposit thinning
outwards (a lower thickness threshold lies further out)."""
from __future__ import annotations

from _scripts import load_script


def test_quick_run_spreads_and_keeps_its_mass():
    mod = load_script("validation/axisymmetric/run.py", "axisymmetric_run")
    (r,) = mod.main(["--quick"])["runs"]
    assert abs(r["mass_rel_error"]) < 1e-13
    assert r["runout_m99"] > 0.05 and r["runout_1pc"] >= r["runout_5pc"] > 0.0
    assert -0.1 < r["energy_residual_rel"] < 0.0
    assert mod.lube_fit(1.0) == 1.24 and abs(mod.lube_fit(4.0) - 3.2) < 1e-12
