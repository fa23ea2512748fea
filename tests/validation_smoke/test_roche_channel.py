"""Roche's channel (issue 13 items 2, 3b, 3c; validation/roche/run.py, examples/roche_channel.toml).

The analysis functions against synthetic series with known answers (a front at constant speed
that stops, a probe dipping below atmospheric as the front passes), and the ``--quick`` channel
(4 cm cells, 0.1 s of injection, 0.4 s of flow): it must run clear of the east wall, start from
an injected reservoir (basal p_f > 0 at the reservoir station at release) and give a front slower
than Ritter's inviscid dam-break front 2 sqrt(g H0) (the fastest a fluid released from rest
spreads in shallow-water theory; Ritter 1892), but moving.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from _scripts import load_script

G = 9.81


@pytest.fixture(scope="module")
def roche():
    return load_script("validation/roche/run.py", "roche_channel_run", cached=True)


def synthetic_front(speed: float, t_stop: float, L0: float = 0.2, dx: float = 0.02) -> dict:
    t = np.arange(0.0, 1.0, 0.02)
    x = L0 + speed * np.minimum(t, t_stop)
    return {"t_s": t.tolist(), "x_front_linear_m": x.tolist(), "x_front_m": x.tolist(), "H0_m": 0.4,
            "L0_m": L0, "dx_m": dx}


def test_front_speed_and_stopping_time_of_a_synthetic_front(roche):
    r = synthetic_front(1.9, 0.5)
    r["t_rest_s"] = 0.6
    out = roche.front_analysis(r)
    assert out["front_speed_m_s"] == pytest.approx(1.9, rel=1e-12)
    assert out["sqrt_2gH0_m_s"] == pytest.approx(math.sqrt(2 * G * 0.4), rel=1e-15)
    assert out["front_speed_over_sqrt_2gH0"] == pytest.approx(1.9 / math.sqrt(2 * G * 0.4), rel=1e-12)
    # the first record within one cell (0.02 m) of the front at rest, 0.2 + 0.95 m: t >= 0.5 - 0.02/1.9
    assert out["t_stop_s"] == pytest.approx(0.5, abs=1e-12)
    assert out["fit_points"] >= 3
    assert out["runout_rest_m"] == pytest.approx(0.95, rel=1e-12)


def test_under_pressure_is_the_lowest_pf_after_the_front_arrives(roche):
    r = synthetic_front(2.0, 0.4)
    t = np.asarray(r["t_s"])
    pf = np.stack([1000.0 * np.ones_like(t), np.where((t > 0.2) & (t < 0.26), -50.0, 10.0)], axis=1)
    r.update(probe_x_m=[0.1, 0.5], probe_p_f_Pa=pf.tolist(), p_lith0_Pa=5000.0)
    res = roche.under_pressure(r)
    assert res[0]["t_arrival_s"] is None  # in the reservoir: not a channel station
    assert res[1]["t_arrival_s"] == pytest.approx(0.16, abs=1e-12)  # first record with x_f > 0.5
    assert res[1]["min_pf_Pa"] == -50.0 and res[1]["min_pf_over_plith0"] == -0.01


def test_quick_channel_runs_clear_of_the_wall_from_an_injected_reservoir(roche):
    r = roche.channel_run("fluidised", roche.QUICK_DX, quick=True)
    assert r["status"] == "completed" and r["wall_contact"] == {}
    assert r["prep"]["prep_time_s"] > 0
    reservoir = r["probe_x_m"].index(min(r["probe_x_m"]))
    assert r["probe_x_m"][reservoir] < r["L0_m"]
    assert np.asarray(r["probe_p_f_Pa"])[0, reservoir] > 0.0
    assert np.all(np.isfinite(r["probe_p_f_Pa"]))
    ritter = 2 * math.sqrt(G * r["H0_m"])
    assert 0.0 < r["front_speed_m_s"] < ritter
