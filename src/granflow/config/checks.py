"""Checks of a validated :class:`granflow.config.CaseConfig` that span sections (any case):
probes inside the box, a reachable step budget, physical ranges, grains smaller than the column,
a yield function that is not negative on the equilibrium line. Each problem is ``(key, message)``.
"""
from __future__ import annotations

from granflow.config.schema import (
    COLUMN_KEYS,
    EQUILIBRIUM_I,
    KEY_SEP,
    MAX_RECORDS,
    MAX_STEPS,
    NUMERICS_RANGES,
    PHYSICAL_RANGES,
)


def common_problems(cfg) -> list[tuple[str, str]]:
    """Consistency of options of the common sections with each other (any case)."""
    out = []
    # a case may take its box length from [setup] (lagree_column: setup.Lx, dimensionless)
    key, length = ("setup.Lx", cfg.setup.Lx) if hasattr(cfg.setup, "Lx") else ("grid.Lx", cfg.grid.Lx)
    bad = [x for x in cfg.output.probes_x if not 0.0 <= x <= length]
    if bad:
        out.append(("output.probes_x", f"{bad} outside the box [0, {key} = {length}]"))
    t = cfg.time
    if t.max_steps is None and t.stop_time / t.dt_max > MAX_STEPS:
        out.append(("time.dt_max", f"stop_time / dt_max = {t.stop_time:g} s / {t.dt_max:g} s = "
                                   f"{t.stop_time / t.dt_max:.3g} steps at least, more than the step "
                                   f"budget of {MAX_STEPS} (granflow.config.MAX_STEPS): the run could "
                                   "not reach stop_time; raise time.dt_max, or set time.max_steps to "
                                   "run part of it"))
    interval = cfg.output.interval
    if t.stop_time / interval > MAX_RECORDS:
        out.append(("output.interval", f"stop_time / interval = {t.stop_time:g} s / {interval:g} s = "
                                       f"{t.stop_time / interval:.3g} records, more than "
                                       f"{MAX_RECORDS} (granflow.config.MAX_RECORDS; the output "
                                       "times also cut the time step); raise output.interval"))
    if not cfg.case.allow_unphysical:
        for name, (lo, hi, unit) in {**PHYSICAL_RANGES, **NUMERICS_RANGES}.items():
            value = cfg
            for part in name.split(KEY_SEP):
                value = getattr(value, part)
            if value is not None and not lo <= value <= hi:
                kind = "numerical" if name in NUMERICS_RANGES else "physical"
                u = "" if unit == "-" else f" {unit}"
                out.append((name, f"{value:g}{u} is outside the {kind} range [{lo:g}, {hi:g}]{u} "
                                  "(set case.allow_unphysical = true for an unusual study)"))
    column = [(f"setup.{k}", getattr(cfg.setup, k)) for k in COLUMN_KEYS if hasattr(cfg.setup, k)]
    column_key, height = column[0] if column else ("grid.Lz", cfg.grid.Lz)
    if isinstance(height, float) and not cfg.material.d < height:
        out.append(("material.d", f"grain diameter {cfg.material.d:g} m is not smaller than the "
                                  f"column ({column_key} = {height:g} m)"))
    if ("fields" in cfg.output.model_fields_set and "c" in cfg.output.fields
            and cfg.numerics.surface != "indicator"):
        out.append(("output.fields", f'"c" (the material fraction) exists only with numerics.surface = '
                                     f'"indicator" (got {cfg.numerics.surface!r})'))
    if cfg.inflow.side != "none" and cfg.inflow.start >= cfg.time.stop_time:
        out.append(("inflow.start", f"{cfg.inflow.start:g} s is not before time.stop_time = "
                                    f"{cfg.time.stop_time:g} s: the source would never run"))
    repeated = sorted({f for f in cfg.output.fields if cfg.output.fields.count(f) > 1})
    if repeated:
        out.append(("output.fields", f"{repeated} given more than once"))
    out += yield_problems(cfg)
    return out


def yield_problems(cfg) -> list[tuple[str, str]]:
    """The yield function Z must be finite and >= 0 on the equilibrium line phi = phi_eq(I) (a
    negative Z is a negative friction coefficient: the solver would only count the cells where it
    is; a non-finite one, e.g. ``exp(1000*I)`` at I = 10 or ``1/I`` at rest, fails the run's steps)."""
    import numpy as np

    closure = cfg.make_closure()
    I = np.concatenate([[EQUILIBRIUM_I[0]], np.logspace(-6, np.log10(EQUILIBRIUM_I[1]), 60)])
    with np.errstate(all="ignore"):
        phi = np.asarray(closure.equilibrium.phi_eq(I), dtype=float)
        keep = phi > 0
        Z = np.asarray(closure.Z(phi[keep], I[keep]), dtype=float)
    key = "closure.expression" if "expression" in cfg.closure.parameters() else "closure"
    if key == "closure.expression":
        from granflow.rheology.derive import parse_yield_function, singular_points

        poles = singular_points(parse_yield_function(cfg.closure.parameters()["expression"]), *EQUILIBRIUM_I)
        if poles:
            return [(key, f"the yield function is singular at I = {poles[0]:.4g} (within "
                          f"{EQUILIBRIUM_I[0]:g} <= I <= {EQUILIBRIUM_I[1]:g})")]
    nonfinite = np.flatnonzero(np.isnan(Z) | (Z == np.inf))
    if nonfinite.size:
        k = nonfinite[0]
        return [(key, f"the yield function is not finite on the equilibrium line: Z(phi_eq(I), I) = "
                      f"{Z[k]:.3g} at I = {I[keep][k]:.3g}")]
    negative = np.flatnonzero(Z < 0)
    if not negative.size:
        return []
    k = negative[0]
    return [(key, f"the yield function is negative on the equilibrium line: Z(phi_eq(I), I) = "
                  f"{Z[k]:.3g} at I = {I[keep][k]:.3g} (a negative friction coefficient)")]


def advisories(cfg) -> list[str]:
    """Option combinations that run but were not validated (warnings, not errors; any case): the
    threshold surface with one solve per step (its validations pinned the converged loop, and
    with one solve the inclined-plane layer stayed unsteady, +57-60 % on u_s: validation/inclined_plane)."""
    out = []
    if cfg.numerics.surface == "threshold" and cfg.numerics.picard.max_sweeps == 1:
        out.append('numerics.surface = "threshold" with one solve per step (numerics.picard.max_sweeps = 1, '
                   "the default): the threshold surface was validated with the converged Picard loop, and "
                   "with one solve an inclined layer stayed unsteady (+57-60 % on its surface speed); add "
                   "--set numerics.picard.max_sweeps=10 --set numerics.picard.predictor=previous "
                   "--set time.cfl=0.3 --set numerics.ambient.velocity_band_margin=0 (docs/cases.md, numerics.surface)")
    return out
