"""The ``granflow`` command line.

Exit codes: 0 success; 1 a check or computation ran but reported failure where the command is a
verdict (``granflow check --strict``); 2 bad input (unknown closure, unknown or invalid parameter,
unparsable expression), printed as one line ``granflow: error: ...`` without a traceback;
3 an unexpected internal error (with the traceback, so it can be reported); ``granflow run`` adds
130 for an interrupted run (see :mod:`granflow.cli.run`); ``granflow sweep`` returns 1 when a member
failed (see :mod:`granflow.cli.sweep`).
"""
from __future__ import annotations

import argparse
import json
import sys
import traceback
from enum import IntEnum

from granflow.errors import GranflowInputError


class ExitCode(IntEnum):
    """Process exit codes of the ``granflow`` command."""

    OK = 0
    FAILED = 1
    BAD_INPUT = 2
    INTERNAL = 3


class _Parser(argparse.ArgumentParser):
    """argparse that reports errors in one line with exit code 2."""

    def error(self, message: str) -> None:  # pragma: no cover - exercised through main()
        raise GranflowInputError(f"{self.prog}: {message}")


def build_parser() -> argparse.ArgumentParser:
    from granflow import __version__
    from granflow.cli import commands

    parser = _Parser(prog="granflow", description="Fluidised granular flows: closures, theory and solver.")
    parser.add_argument("--version", action="version", version=f"granflow {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    from granflow.cli import run as run_cli

    p = sub.add_parser("list", help="list registered parts")
    p.add_argument("what", choices=["closures", "equilibria", "cases"])
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=run_cli.cmd_list)
    run_cli.add_parsers(sub, _Parser)
    from granflow.cli import export as export_cli
    from granflow.cli import plot as plot_cli
    from granflow.cli import sweep as sweep_cli

    sweep_cli.add_parser(sub)
    plot_cli.add_parser(sub)
    export_cli.add_parser(sub)

    def closure_args(q: argparse.ArgumentParser) -> None:
        q.add_argument("closure", help="closure registry key (granflow list closures)")
        q.add_argument("--set", action="append", metavar="KEY=VALUE", default=[],
                       help="closure parameter, or material.<name> / equilibrium.<name>; TOML values")
        q.add_argument("--equilibrium", default="linear", help="equilibrium law (granflow list equilibria)")

    p = sub.add_parser("check", help="check C1-C3, dissipation, equilibrium and Z >= 0 for a closure")
    closure_args(p)
    p.add_argument("--json", action="store_true")
    p.add_argument("--plot", metavar="PNG", help="write Z, f against I/I_eq and a well-posedness map")
    p.add_argument("--strict", action="store_true", help="exit 1 if any condition fails")
    p.set_defaults(func=commands.cmd_check)

    p = sub.add_parser("stability", help="linear stability: Barker window, dispersion relation")
    ssub = p.add_subparsers(dest="stability_command", required=True, parser_class=_Parser)
    w = ssub.add_parser("window", help="Barker et al. (2015) well-posed window of incompressible mu(I)")
    w.add_argument("--mu1", type=float, required=True)
    w.add_argument("--mu2", type=float, required=True)
    w.add_argument("--I0", type=float, required=True)
    w.add_argument("--c-I", dest="c_I", type=float, default=2.0,
                   help="convention of I0 and of the reported window: 2 literature (default), 1 paper")
    w.add_argument("--json", action="store_true")
    w.set_defaults(func=commands.cmd_window)
    d = ssub.add_parser("dispersion", help="growth rate of perturbations about uniform simple shear")
    closure_args(d)
    d.add_argument("--phi", type=float, help="base packing fraction (default phi_eq(I))")
    d.add_argument("--p", type=float, default=1000.0, help="base granular pressure [Pa] (default 1000)")
    d.add_argument("--I", type=float, default=1e-2, help="base inertial number (default 1e-2)")
    d.add_argument("--p-f", dest="p_f", type=float, default=0.0, help="base pore pressure [Pa] (default 0)")
    d.add_argument("--gas", choices=["linear", "nonlinear"], default="linear")
    d.add_argument("--json", action="store_true")
    d.add_argument("--plot", metavar="PNG", help="write growth rate against direction and wavenumber")
    d.set_defaults(func=commands.cmd_dispersion)

    p = sub.add_parser("derive", help="derive f from a yield function Z(phi, I) (eq. f-general) and check it")
    p.add_argument("expression", help='Z in phi and I, e.g. "0.38 + 0.27*I/(I + 0.3)"')
    p.add_argument("--set", action="append", metavar="KEY=VALUE", default=[],
                   help="material.<name> / equilibrium.<name> overrides")
    p.add_argument("--equilibrium", default="linear")
    p.add_argument("--json", action="store_true")
    p.add_argument("--latex", action="store_true", help="also print f in LaTeX")
    p.set_defaults(func=commands.cmd_derive)
    return parser


INTERRUPTED = 130
"""Exit code of a command interrupted by Ctrl-C (128 + SIGINT), as ``granflow run``'s."""


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``granflow`` command; returns the exit code."""
    try:
        parser = build_parser()
        args = parser.parse_args(argv)
        return int(args.func(args))
    except GranflowInputError as err:
        print(f"granflow: error: {err}", file=sys.stderr)
        return ExitCode.BAD_INPUT
    except BrokenPipeError:  # output piped into `head` and closed early
        sys.stderr.close()
        return ExitCode.OK
    except KeyboardInterrupt:  # Ctrl-C before a run's own handler is installed (start-up)
        print("granflow: interrupted", file=sys.stderr)
        return INTERRUPTED
    except SystemExit as exc:  # --help / --version
        return int(exc.code or 0)
    except Exception:  # noqa: BLE001 - last resort: show it, it is a bug
        traceback.print_exc()
        return ExitCode.INTERNAL


def _json(obj) -> str:
    return json.dumps(obj, indent=2, allow_nan=False)
