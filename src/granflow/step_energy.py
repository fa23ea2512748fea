"""Stage 3 of a step of :class:`granflow.model.Model` (:mod:`granflow.step`): the step's powers for
the energy budget (:class:`granflow.diagnostics.EnergyBudget`, NUMERICS.md §9).

Each power is the sum over the control volumes of the discrete momentum equation times
``u^{n+1}``: ``dV`` per unit width in a plane [W m^-1]; on an axisymmetric grid every face's and
cell's term carries its ring's circumference ``2 pi r`` (:mod:`granflow.model_geometry`), so the
powers are those of the whole cylinder [W].
"""
from __future__ import annotations


from granflow.physics import momentum_transport as mt


def energy_terms(model, state, dt: float, ex, im) -> dict:
    """The step's powers (:class:`granflow.model_options.StepReport`): yield/viscous and
    dilatancy dissipation, the backward-Euler inertia term, the momentum transport's numerical
    power, the gravity and the source powers. ``ex``, ``im``: the step's
    :class:`granflow.step.Explicit` and :class:`granflow.step.Implicit`."""
    dV = model.grid.cell_volume
    du = im.u - state.vel
    # the penalty of a source sits in ex.drag (and its lambda u_in in the rhs): its work is the
    # source's, not gravity's
    src_power, src_drag = 0.0, 0.0
    if ex.source is not None:
        src_power = ex.source.power(dV, im.u)
        src_drag = dV * float(ex.source.penalty @ (im.u * im.u))
    if im.flux_div is not None:
        adv_pow = mt.advection_energy_rate(model.material.rho_s, dV, model.on_unknowns(im.flux_div[0]),
                                           model.on_unknowns(im.flux_div[1]), im.u)
    else:
        adv_pow = dV * float((ex.rho_n * ex.adv) @ im.u)
    return dict(dissipation_yield=model.dissipation(im.u, *im.eta),
                dissipation_dilatancy=-dV * float(model.on_cells(im.p_solve) @ im.div_u),
                inertia_dissipation=0.5 * dV * float(model.on_unknowns(ex.rho_n) @ (du * du)) / dt,
                advection_power=adv_pow,
                gravity_power=dV * float(model.on_unknowns(ex.f_g - ex.drag * im.u) @ im.u) + src_drag,
                source_power=src_power,
                solve_power=0.0 if im.residual_u is None else dV * float(im.residual_u @ im.u))
