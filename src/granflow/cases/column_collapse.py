"""Case ``column_collapse``: a rectangular granular column released at t = 0 (issue 4).

The column ``[0, L0] x [0, H0]`` (cells cut by its edges are filled in proportion to the covered
area, so the initial mass is exactly ``phi0 H0 L0`` per unit width) rests against the west wall of
the box. With the default free-slip west wall that wall is a symmetry plane, so ``L0`` is the
half-width of a symmetric column of width ``2 L0`` (Lajeunesse et al. 2005; Lube et al. 2005;
Lagree, Staron & Popinet 2011). The base is no-slip by default; tilt gravity with
``gravity.slope_deg`` for an inclined base. The initial pressure is the discrete lithostatic one
(:meth:`granflow.model.Model.lithostatic_pressure`), the first Picard iterate.

Dry by default. An initially fluidised column -- pore pressure ``p_f = b0`` times the lithostatic
pressure, typically with an expanded packing ``phi0 < phi_max`` -- needs ``[gas] law = "linear"``
or ``"nonlinear"`` (without one, ``setup.b0 > 0`` is refused at load time).

Prepared like the experiments (``setup.preparation = "injection"``; Roche et al. 2002, Roche
2012): the column is first fluidised by gas injected through the reservoir's porous base at
``U_prep = U_prep_over_Umf * U_mf`` in a separate simulation of the reservoir alone (gate closed)
until steady or ``prep_max_time``; its phi, p and p_f are the initial state, and the injection
stops when the gate opens (or continues under the reservoir or the whole base,
``setup.keep_injection``). See :mod:`granflow.casekit.preparation`.
"""
from __future__ import annotations

from typing import Any, Literal

import numpy as np
from pydantic import Field

from granflow.casekit.common import (
    axisymmetric_problems,
    column_on_base,
    extent_problems,
    gas_problems,
    initial_state,
    make_model,
    make_simulation,
    packing,
    packing_problems,
)
from granflow.casekit.preparation import (
    DEFAULT_PREP_MAX_TIME,
    DEFAULT_U_PREP_OVER_UMF,
    Preparation,
    collapse_injection,
    model_with_injection,
    preparation_problems,
    prepare,
    released_state,
)
from granflow.casekit import headlines
from granflow.casekit.registry import CASES
from granflow.config import CaseConfig, Section
from granflow.simulation import Simulation
from granflow.topography import base_height

PREPARATION_ATTRIBUTE = "preparation"
"""Attribute of the Simulation holding the preparation result (read by :func:`diagnostics`)."""


class ColumnCollapseSetup(Section):
    """``[setup]`` of ``column_collapse``."""

    H0: float = Field(0.1, gt=0, description="initial column height [m]")
    L0: float = Field(0.1, gt=0, description="initial column width from the west wall (the "
                      "half-width of a symmetric column when the west wall is free-slip) [m]")
    phi0: float | None = Field(None, gt=0, lt=1, description="initial packing fraction "
                               "(default: material.phi_max) [-]")
    b0: float = Field(0.0, ge=0, le=1, description="initial pore pressure as a fraction of the "
                      "lithostatic pressure (needs [gas]) [-]")
    preparation: Literal["none", "injection"] = Field(
        "none", description='initial state: "none" (phi0 and b0 as given) or "injection" (the column '
        "is first fluidised by gas injected through its base until steady, gate closed, as in the "
        "experiments; needs [gas]) [-]")
    U_prep_over_Umf: float | None = Field(
        None, gt=0, description="injection: superficial gas velocity of the preparation over the "
        f"minimum fluidisation velocity U_mf = kappa(phi0) phi0 rho_s g [-] (default "
        f"{DEFAULT_U_PREP_OVER_UMF})")
    prep_max_time: float | None = Field(
        None, gt=0, description="injection: the preparation stops when steady or after this time "
        f"[s] (default {DEFAULT_PREP_MAX_TIME})")
    keep_injection: Literal["none", "reservoir", "base"] = Field(
        "none", description='injection: gas supply after the gate opens: "none" (stopped, as in '
        'the experiments), "reservoir" (U_prep through the base under x < L0) or "base" (U_prep '
        "through the whole base) [-]")


def check(config: CaseConfig) -> list[tuple[str, str]]:
    s = config.setup
    out = packing_problems(config) + gas_problems(config) + preparation_problems(config)
    out += extent_problems(config, "setup.H0", s.H0, "z") + extent_problems(config, "setup.L0", s.L0, "x")
    if s.L0 >= config.grid.Lx:
        out.append(("setup.L0", f"{s.L0} m leaves no room to spread (grid.Lx = {config.grid.Lx} m)"))
    if config.grid.periodic_x:
        out.append(("grid.periodic_x", "a column collapse needs its west (symmetry) and east walls; "
                                       "set periodic_x = false"))
    if s.b0 > 0 and config.gas.law == "none":
        out.append(("setup.b0", 'an initial pore pressure needs gas.law = "linear" or "nonlinear"'))
    return out + topography_problems(config) + axisymmetric_problems(config)


def topography_problems(config: CaseConfig) -> list[tuple[str, str]]:
    """A base profile (``[topography]``): the column stands on it, so it must fit above it, and
    the injection preparation (a bed on the flat porous base) is not available on it."""
    topo, s, g = config.make_topography(), config.setup, config.grid
    if topo is None:
        return []
    out = []
    if s.preparation == Preparation.INJECTION:
        out.append(("setup.preparation", '"injection" prepares the bed on the flat porous base; it is '
                                         "not available with a [topography] (use \"none\" and setup.b0)"))
    top = float(np.max(topo.height(np.linspace(0.0, min(s.L0, g.Lx), 201))))
    if top + s.H0 > g.Lz:
        out.append(("setup.H0", f"the column ({s.H0} m) on the profile (up to z = {top:.4g} m under it) "
                                f"does not fit below the lid (grid.Lz = {g.Lz} m)"))
    return out


def diagnostics(sim: Simulation, config: CaseConfig) -> dict[str, Any]:
    """Aspect ratio and normalised run-out inputs: a = H0/L0, initial mass; with an injection
    preparation its outcome (:meth:`granflow.casekit.preparation.PreparationResult.diagnostics`)."""
    s = config.setup
    out = {"H0_m": s.H0, "L0_m": s.L0, "aspect_ratio": s.H0 / s.L0, "phi0": packing(config),
           "b0": s.b0, "preparation": s.preparation}
    prep = getattr(sim, PREPARATION_ATTRIBUTE, None)
    if prep is not None:
        out.update(prep.diagnostics(), keep_injection=s.keep_injection)
    return out


FRONT_THRESHOLD_FRACTION = 0.05
"""Default front threshold: deposit thickness of this fraction of H0 (5 mm for a 10 cm column), a
physical length so that run-outs at different resolutions compare (the run-out moves by up to
30 % between 2 and 10 mm thresholds, validation/fluidised_vs_dry/README.md)."""


def front_threshold(config: CaseConfig) -> float:
    """Deposit thickness [m] defining the front: :data:`FRONT_THRESHOLD_FRACTION` x H0."""
    return FRONT_THRESHOLD_FRACTION * config.setup.H0


@CASES.register("column_collapse", setup_model=ColumnCollapseSetup, check=check,
                diagnostics=diagnostics, front_threshold=front_threshold,
                headline=headlines.column_collapse, settles=True,
                summary="rectangular column H0 x L0 against the west wall collapses and spreads")
def setup(config: CaseConfig) -> Simulation:
    """Model, initial state and stop criteria of a column collapse.

    Parameters
    ----------
    config : CaseConfig
        With ``case.name = "column_collapse"``.

    Returns
    -------
    Simulation
        With ``setup.preparation = "injection"``, its attribute ``preparation`` is the
        :class:`~granflow.casekit.preparation.PreparationResult`.
    """
    s = config.setup
    if s.preparation == Preparation.INJECTION:
        prep = prepare(config)
        model = model_with_injection(config, collapse_injection(config, prep))
        sim = make_simulation(config, model, released_state(model, prep))
        setattr(sim, PREPARATION_ATTRIBUTE, prep)
        return sim
    model = make_model(config)
    g = model.grid
    # the column stands on the base: the box's, or the staircase of a [topography]
    phi = packing(config) * column_on_base(g, 0.0, s.L0, s.H0, base_height(g, model.solid))
    return make_simulation(config, model, initial_state(model, phi, s.b0))
