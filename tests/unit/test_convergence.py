"""Richardson extrapolation (granflow.verification.convergence) on sequences with a known limit."""
from __future__ import annotations

import math

import pytest

from granflow.verification.convergence import richardson


@pytest.mark.parametrize("p, ratio", [(1.0, 2.0), (1.7, 2.0), (0.8, math.sqrt(2.0))])
def test_three_levels_recover_the_limit_and_order(p, ratio):
    f_star, C, h0 = 3.25, -0.7, 0.1
    values = [f_star + C * (h0 / ratio**k) ** p for k in range(3)]
    est = richardson(values, ratio)
    assert est["method"] == "3-level Richardson"
    assert est["order"] == pytest.approx(p, rel=1e-10)
    assert est["value"] == pytest.approx(f_star, rel=1e-12)
    # GCI = 1.25 |extrapolation step|
    assert est["uncertainty"] == pytest.approx(1.25 * abs(est["value"] - values[-1]), rel=1e-12)


def test_oscillating_levels_fall_back_to_first_order_with_safety_3():
    est = richardson([1.0, 1.2, 1.1], 2.0)
    assert est["method"] == "1st-order fallback"
    assert est["value"] == pytest.approx(1.0) and est["uncertainty"] == pytest.approx(0.3)


def test_two_levels_and_one():
    est = richardson([2.0, 2.1], 2.0)
    assert est["value"] == pytest.approx(2.2) and est["uncertainty"] == pytest.approx(0.3)
    assert richardson([5.0])["method"] == "single level"


def test_mesh_estimate_keeps_the_finest_of_an_oscillating_sequence():
    from granflow.verification.convergence import mesh_estimate

    est = mesh_estimate([2.16, 2.23, 2.09], math.sqrt(2.0))
    assert est["method"].startswith("oscillatory")
    assert est["value"] == 2.09 and est["uncertainty"] == pytest.approx(0.5 * (2.23 - 2.09))
    # monotone: the three-level Richardson estimate of a manufactured sequence, order 1.3
    f_star, p, ratio = 1.5, 1.3, math.sqrt(2.0)
    values = [f_star + 0.4 * ratio ** (-k * p) for k in range(3)]
    assert mesh_estimate(values, ratio) == richardson(values, ratio)
    assert mesh_estimate(values, ratio)["value"] == pytest.approx(f_star, rel=1e-12)


def test_ratio_estimate_adds_relative_uncertainties():
    from granflow.verification.convergence import ratio_estimate

    r = ratio_estimate({"value": 4.0, "uncertainty": 0.4}, {"value": -2.0, "uncertainty": 0.1})
    assert r["value"] == -2.0 and r["uncertainty"] == pytest.approx(2.0 * (0.1 + 0.05))
