"""The end-of-run headline of each case: its own result, from the ``summary.json`` content.

A column collapse reports its run-out; a verification case reports its error against its
reference (``granflow run`` prints "run-out 0 m" for none of them). Each function takes the
summary dict and returns one short phrase; missing values print as ``n/a``.
"""
from __future__ import annotations

import math
from typing import Any

NA = "n/a"


def num(value: Any, spec: str = ".4g", unit: str = "") -> str:
    """``value`` formatted with ``spec`` (and `` unit``), or ``n/a`` for None/NaN."""
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return NA
    return f"{value:{spec}}" + (f" {unit}" if unit else "")


def percent(value: Any) -> str:
    """A relative error as a signed percentage (``+3.3 %``), or ``n/a``."""
    return NA if value is None else f"{100.0 * value:+.3g} %"


def runout(summary: dict, length: str = "m") -> str:
    """``run-out 0.15 m (front 0.25 m)``."""
    fp = summary.get("front_position") or {}
    return f"run-out {num(summary.get('runout_m'), unit=length)} (front {num(fp.get('final_m'), unit=length)})"


def column_collapse(summary: dict) -> str:
    return runout(summary)


def lagree_column(summary: dict) -> str:
    ro = (summary.get("case_diagnostics") or {}).get("runout") or {}
    return (f"run-out {num(summary.get('runout_m'), unit='H0')}, x_f = {num(ro.get('x_f'), unit='H0')}, "
            f"(x_f - L0)/L0 = {num(ro.get('relative'), '.3g')}, lambda1 = {num(ro.get('lambda1'), '.3g')}")


def defluidisation_column(summary: dict) -> str:
    cd = summary.get("case_diagnostics") or {}
    return (f"basal p_f half-life {num(cd.get('half_life_s'), '.4g', 's')} against the series' "
            f"{num(cd.get('series_half_life_s'), '.4g', 's')} ({percent(cd.get('half_life_rel_error'))}); "
            f"largest basal p_f error {num(cd.get('max_error_rel'), '.2e')} of p_f0")


def sheared_layer(summary: dict) -> str:
    cd = summary.get("case_diagnostics") or {}
    return (f"phi relaxes towards phi_eq = {num(cd.get('phi_eq'), '.5g')}: largest error against the "
            f"{cd.get('reference') or 'reference'} {num(cd.get('max_error_rel'), '.2e')} of |phi0 - phi_eq|, "
            f"remaining distance {num(cd.get('final_distance_rel'), '.2e')}")


def inclined_layer(summary: dict) -> str:
    cd = summary.get("case_diagnostics") or {}
    u_s = num(cd.get("u_surface_m_s"), ".4g", "m/s")
    steady = "steady" if cd.get("steady") else "not yet steady"
    if cd.get("u_surface_bagnold_m_s") is None:
        return f"surface speed u_s = {u_s} ({steady}; no Bagnold reference for this closure)"
    return (f"surface speed u_s = {u_s} against Bagnold {num(cd.get('u_surface_bagnold_m_s'), '.4g', 'm/s')} "
            f"({percent(cd.get('u_surface_rel_error'))}), profile error "
            f"{num(cd.get('profile_max_error_rel'), '.2e')} of u_s ({steady})")


def static_layer(summary: dict) -> str:
    cd = summary.get("case_diagnostics") or {}
    return (f"largest speed {num(cd.get('max_speed_m_s'), '.2e', 'm/s')}; granular pressure against "
            f"lithostatic: largest error {num(cd.get('pressure_rel_error'), '.2e')}")
