"""Defluidisation of static beds (issue 13 item 3d; validation/roche/defluidisation.py): the
``--quick`` runs (H = 0.1 m, 80 um beads, 10 cells) against the model's two limits -- the rigid
bed's diffusion series and Kynch's consolidation of an expanded bed -- and the H-exponent fit on
synthetic rows with known answers."""
from __future__ import annotations

import pytest

from _scripts import load_script


@pytest.fixture(scope="module")
def defl():
    return load_script("validation/roche/defluidisation.py", "roche_defluidisation", cached=True)


@pytest.fixture(scope="module")
def quick(defl):
    return defl.main(["--quick"])


def test_rigid_bed_follows_the_diffusion_series(quick):
    rigid = next(r for r in quick if r["phi0"] == 0.6)
    assert rigid["rigid"] and rigid["half_life_over_series"] == pytest.approx(1.0, abs=0.02)
    assert rigid["D_app_m2_s"] == pytest.approx(rigid["D_m2_s"], rel=0.02)


def test_expanded_bed_settles_as_kynch_and_retards_the_decay(quick):
    """An expanded bed holds its pore pressure ~10x longer than the packed one (Roche 2012,
    Montserrat et al. 2012: expansion retards the decay); its basal p_f falls linearly at Kynch's
    rate once the gas's storage is removed (p_atm x 100), slower with it."""
    rigid = next(r for r in quick if r["phi0"] == 0.6)
    exp, control = (next(r for r in quick if r["phi0"] == 0.585 and r["p_atm_factor"] == f) for f in (1.0, 100.0))
    assert not exp["rigid"] and exp["half_life_s"] > 5 * rigid["half_life_s"]
    assert control["slope_over_kynch"] == pytest.approx(1.0, abs=0.06)
    assert 0.6 < exp["slope_over_kynch"] < control["slope_over_kynch"] - 0.05


def test_exponents_of_synthetic_rows(defl):
    rows = [{"d_m": 80e-6, "phi0": phi0, "p_atm_factor": 1.0, "H_m": H, "half_life_s": c * H**k}
            for phi0, c, k in ((0.6, 3.0, 2.0), (0.585, 2.0, 1.0)) for H in (0.05, 0.1, 0.2)]
    ex = {e["phi0"]: e["exponent"] for e in defl.exponents(rows)}
    assert ex[0.6] == pytest.approx(2.0) and ex[0.585] == pytest.approx(1.0)
