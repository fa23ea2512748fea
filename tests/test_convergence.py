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
