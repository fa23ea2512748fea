"""Handlers of the ``granflow`` sub-commands (argparse namespace in, exit code out).

Heavy imports (SymPy derivation, SciPy eigen-solvers, matplotlib) happen inside the handlers.
"""
from __future__ import annotations

import argparse
from typing import Any

from granflow.cli import ExitCode, _json
from granflow.cli.overrides import parse_overrides
from granflow.errors import GranflowInputError

_BASE_FIELDS = {"material", "equilibrium"}
#: Wavenumber and direction samples of ``granflow stability dispersion``.
DISPERSION_K_POINTS = 25
DISPERSION_THETA_POINTS = 36
DISPERSION_ERRORS = (ValueError, ZeroDivisionError, FloatingPointError, OverflowError)
"""What the eigenvalue problems raise on a base state with infinite or NaN coefficients (e.g.
``--p 1e300``, ``--I 1e-300``, ``material.rho_s = 1e300``: exit 3 before)."""


def _field_table(cls) -> dict[str, dict[str, Any]]:
    out = {}
    for name, field in cls.model_fields.items():
        if name in _BASE_FIELDS:
            continue
        default = field.default
        if hasattr(default, "value"):
            default = default.value
        if isinstance(default, tuple):
            default = list(default)
        out[name] = {"default": default, "description": field.description or ""}
    return out


def cmd_list(args: argparse.Namespace) -> int:
    from granflow.equilibrium import EQUILIBRIUM_LAWS
    from granflow.rheology import CLOSURES

    if args.what == "closures":
        data = {
            n: {
                "summary": CLOSURES.get(n).summary,
                "reference": CLOSURES.get(n).reference,
                "source": CLOSURES.get(n).source,
                "parameters": _field_table(CLOSURES.get(n)),
            }
            for n in CLOSURES
        }
    else:
        data = {
            n: {"formula": EQUILIBRIUM_LAWS.get(n).formula, "parameters": _field_table(EQUILIBRIUM_LAWS.get(n))}
            for n in EQUILIBRIUM_LAWS
        }
    if args.json:
        print(_json(data))
        return ExitCode.OK
    for name, info in data.items():
        head = info.get("summary") or info.get("formula")
        tag = "  [reference]" if info.get("reference") else ""
        print(f"{name}{tag}\n    {head}")
        for pname, p in info["parameters"].items():
            print(f"    {pname} = {p['default']!r}  {p['description']}")
    return ExitCode.OK


def closure_from_args(args: argparse.Namespace):
    """Build the closure named on the command line with its ``--set`` overrides."""
    from granflow.rheology import make_closure

    ov = parse_overrides(args.set)
    return make_closure(
        args.closure,
        material=ov["material"] or None,
        equilibrium=args.equilibrium,
        equilibrium_params=ov["equilibrium"],
        **ov["closure"],
    )


def _finite(args: argparse.Namespace, *names: str) -> None:
    """Refuse NaN or infinite numeric options (argparse's float() accepts "inf" and "nan")."""
    import math

    for name in names:
        value = getattr(args, name)
        if value is not None and not math.isfinite(value):
            raise GranflowInputError(f"--{name.replace('_', '-')} must be a finite number (got {value})")


def _all_finite(data: Any) -> bool:
    """Whether every number in a nested dict/list result is finite."""
    import math

    if isinstance(data, dict):
        return all(_all_finite(v) for v in data.values())
    if isinstance(data, (list, tuple)):
        return all(_all_finite(v) for v in data)
    return not isinstance(data, float) or math.isfinite(data)


def _nonfinite_base_state(phi: float, args: argparse.Namespace, why: str) -> GranflowInputError:
    return GranflowInputError(
        f"stability dispersion: the base state (--phi {phi:g}, --p {args.p:g}, --I {args.I:g}, "
        f"--p-f {args.p_f:g}) with these material.* values gives non-finite coefficients ({why}); "
        "use values of physical size")


def _all_pass(report_dict: dict) -> bool:
    return all(c["pass"] for c in report_dict["conditions"].values())


def _check_plot_path(path: str | None) -> None:
    """``--plot PNG``: a writable file of an image format matplotlib writes (before computing)."""
    if path is None:
        return
    from pathlib import Path

    from granflow.cli.plot import _check_format
    from granflow.output.paths import check_file

    check_file(path, "--plot")
    _check_format(Path(path), "--plot")


def _make_parent(path: str) -> None:
    from pathlib import Path

    Path(path).parent.mkdir(parents=True, exist_ok=True)


def cmd_check(args: argparse.Namespace) -> int:
    _check_plot_path(args.plot)
    closure = closure_from_args(args)
    from granflow.theory.conditions import check

    report = check(closure)
    data = report.to_dict()
    if args.plot:
        from granflow import plotting

        _make_parent(args.plot)
        plotting.closure_overview(closure, args.plot)
        data["plot"] = args.plot
    if args.json:
        print(_json(data))
    else:
        print(report.summary_table())
        if args.plot:
            print(f"figure written to {args.plot}")
    if args.strict and not _all_pass(data):
        return ExitCode.FAILED
    return ExitCode.OK


def cmd_window(args: argparse.Namespace) -> int:
    _finite(args, "mu1", "mu2", "I0", "c_I")
    for name in ("mu1", "mu2", "I0", "c_I"):
        if not getattr(args, name) > 0:
            raise GranflowInputError(f"--{name.replace('_', '-')} must be positive (got {getattr(args, name)})")
    if not args.mu2 > args.mu1:
        raise GranflowInputError(f"--mu2 ({args.mu2}) must exceed --mu1 ({args.mu1})")
    from granflow.theory.barker import barker_window

    window = barker_window(args.mu1, args.mu2, args.I0, c_I=args.c_I)
    data = window.to_dict()
    if args.json:
        print(_json(data))
    else:
        for k, v in data.items():
            print(f"{k:>20}: {v}")
    return ExitCode.OK


def cmd_dispersion(args: argparse.Namespace) -> int:
    import numpy as np

    _check_plot_path(args.plot)
    _finite(args, "phi", "p", "I", "p_f")
    closure = closure_from_args(args)
    if not args.p > 0:
        raise GranflowInputError(f"--p must be positive (got {args.p})")
    if not args.I > 0:
        raise GranflowInputError(f"--I must be positive (got {args.I})")
    phi = args.phi if args.phi is not None else float(closure.equilibrium.phi_eq(args.I))
    if not 0 < phi < 1:
        raise GranflowInputError(f"--phi must be in (0, 1) (got {phi})")
    from granflow.theory import dispersion

    import warnings

    k_values = np.logspace(0.0, np.log10(2.0 * np.pi / closure.material.d), DISPERSION_K_POINTS)
    thetas = np.linspace(0.0, np.pi, DISPERSION_THETA_POINTS, endpoint=False)
    state = (closure, phi, args.p, args.I)
    try:
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            lead = dispersion.leading_order_max_growth(*state, p_f=args.p_f, gas=args.gas)
            best = dispersion.most_unstable(*state, k_values, thetas, p_f=args.p_f, gas=args.gas)
            curve = dispersion.growth_curve(*state, k_values, thetas, p_f=args.p_f, gas=args.gas)
    except DISPERSION_ERRORS as err:
        raise _nonfinite_base_state(phi, args, " ".join(str(err).split())[:80]) from None
    data = {
        "closure": closure.name,
        "parameters": closure.parameters(),
        "base_state": {"phi": phi, "p": args.p, "I": args.I, "p_f": args.p_f, "gas": args.gas},
        "leading_order": lead.to_dict(),
        "most_unstable": best.to_dict(),
        "growth_curve": curve.to_dict(),
        "units": {"p": "Pa", "p_f": "Pa", "leading_order.growth": "m^2/s", "most_unstable.growth": "1/s",
                  "k": "1/m", "theta": "rad"},
    }
    if not _all_finite(data):
        raise _nonfinite_base_state(phi, args, "NaN or infinite growth rates")
    if args.plot:
        from granflow import plotting

        _make_parent(args.plot)
        plotting.growth_figure(lead, curve, args.plot,
                               title=f"{closure.name}: phi={phi:.4g}, p={args.p:g} Pa, I={args.I:g}")
        data["plot"] = args.plot
    if args.json:
        print(_json(data))
    else:
        print(f"closure {closure.name} about uniform simple shear: phi={phi:.6g}, p={args.p:g} Pa, I={args.I:g}, "
              f"p_f={args.p_f:g} Pa ({args.gas} gas law)")
        print(f"  leading order (k -> inf): max lambda/k^2 = {lead.growth:.4g} m^2/s "
              f"({lead.growth / lead.scale:.3g} x eta/(phi rho_s)) at theta = {np.degrees(lead.theta):.2f} deg")
        print(f"  finite k: max growth {best.growth:.4g} 1/s at k = {best.k:.4g} 1/m, "
              f"theta = {np.degrees(best.theta):.2f} deg" + (" (at the largest k scanned)" if best.at_largest_k else ""))
        print("  verdict: " + _verdict(lead))
        if args.plot:
            print(f"figure written to {args.plot}")
    return ExitCode.OK


def _verdict(lead) -> str:
    """Plain-language reading of the leading-order growth (tolerance: 1e-10 of eta/(phi rho_s))."""
    tol = 1e-10 * lead.scale
    if lead.growth > tol:
        return "growth ~ k^2 without bound (ill posed)"
    if lead.growth >= -tol:
        return ("marginal at leading order (zero growth along one direction): lower-order terms decide; "
                "see the finite-k growth above")
    return "bounded growth (well posed at high wavenumber)"


def readable_dilatancy(derivation):
    """``(W, f)`` for display: logarithms expanded (log(3^81/(10 I + 3)^81) becomes
    81 log 3 - 81 log(10 I + 3), then the log terms collected), so that no huge rational appears;
    f is written as W(I) - (I_eq/I) W(I_eq) from that W. Equal to ``derivation.f``."""
    import sympy as sp

    from granflow.rheology.derive import I, I_eq

    def tidy(expr):
        expr = sp.expand(sp.expand_log(expr, force=True))
        logs = sorted(expr.atoms(sp.log), key=str)
        return sp.collect(expr, logs, func=sp.factor) if logs else sp.factor(expr)

    W = tidy(derivation.W)
    return W, W - I_eq / I * W.subs(I, I_eq)


def cmd_derive(args: argparse.Namespace) -> int:
    import sympy as sp

    from granflow.rheology import derive_dilatancy, make_closure

    ov = parse_overrides(args.set)  # bad --set items before the derivation
    if ov["closure"]:
        raise GranflowInputError(
            f"derive: unexpected closure parameter(s) {', '.join(ov['closure'])}; only material.* and equilibrium.*"
        )
    derivation = derive_dilatancy(args.expression)
    closure = make_closure(
        "generic", material=ov["material"] or None, equilibrium=args.equilibrium,
        equilibrium_params=ov["equilibrium"], expression=args.expression,
    )
    from granflow.theory.conditions import check

    report = check(closure)
    W, f_readable = readable_dilatancy(derivation)
    data = {
        "Z": str(derivation.Z),
        "f": str(f_readable),
        "W": str(W),
        "f_structure": "f = W(phi, I) - (I_eq/I) W(phi, I_eq)",
        "f_latex": sp.latex(f_readable),
        "note": "f in terms of phi, I and I_eq = I_eq(phi) of the chosen equilibrium law (eq. f-general)",
        "check": report.to_dict(),
    }
    if args.json:
        print(_json(data))
    else:
        print(f"Z(phi, I) = {data['Z']}")
        print(f"f(phi, p, I) = W(phi, I) - (I_eq/I) W(phi, I_eq),  W(phi, I) = {data['W']}")
        print(f"  f = {data['f']}")
        if args.latex:
            print(f"  LaTeX: {data['f_latex']}")
        print(f"  (I_eq = I_eq(phi), equilibrium law {args.equilibrium!r})")
        print(report.summary_table())
    return ExitCode.OK
