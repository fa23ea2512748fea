"""Symbolic derivation of the dilatancy function f from a yield function Z (paper eq. f-general).

Recipe (paper §6.3): C1, Z - (I/2) dZ/dI = f + I df/dI = d(I f)/dI, is integrated in I and the
constant fixed by the equilibrium condition f(phi, p, I_eq(phi)) = 0:

    W(phi, I) = (3/(2I)) int_{I1}^{I} Z(phi, J) dJ - Z(phi, I)/2,
    f(phi, p, I) = W(phi, I) - I_eq W(phi, I_eq) / I.

I1 drops out of f; it is taken as 0 when Z is integrable there (so that W(phi, 0) = Z(phi, 0)
and the divergence law is finite as |S| -> 0), else 1.
"""
from __future__ import annotations

import contextlib
import math
import signal
import threading
from dataclasses import dataclass

import sympy as sp
from sympy.parsing.sympy_parser import (
    convert_xor,
    implicit_multiplication_application,
    parse_expr,
    standard_transformations,
)

from granflow.errors import GranflowInputError

#: The symbols expressions are written in: packing fraction, inertial number, equilibrium I.
phi, I, I_eq = sp.symbols("phi I I_eq", positive=True)
_J = sp.Symbol("J", positive=True)

_ALLOWED_FUNCTIONS = {
    name: getattr(sp, name)
    for name in ("sqrt", "exp", "log", "sin", "cos", "tan", "atan", "tanh", "pi", "E", "Rational")
}
_ALLOWED_FUNCTIONS["ln"] = sp.log
MAX_EXPONENT = 64
"""Largest magnitude of a numeric exponent of a term in phi or I: SymPy expands and integrates
powers as dense polynomials (``I**1e10`` or ``(1 + I)**200`` never finished; ``(0.4 + I)**64``
takes 9 s)."""
DERIVE_TIME_BUDGET_S = 60.0
"""Wall-clock budget of :func:`derive_dilatancy` [s] (main thread only, where a POSIX timer can
interrupt SymPy): a derivation that does not finish in it is bad input, not a hang."""


def parse_yield_function(text: str) -> sp.Expr:
    """Parse a yield function Z written in ``phi`` and ``I`` (e.g. ``"0.4 + 0.2*I/(I + 0.3)"``).

    ``^`` means power. Only the symbols ``phi`` and ``I`` and elementary functions (sqrt, exp,
    log/ln, sin, cos, tan, atan, tanh) are accepted. Decimal numbers are converted to exact
    rationals.

    Raises
    ------
    GranflowInputError
        If the text does not parse, or uses other symbols.
    """
    if not isinstance(text, str) or not text.strip():
        raise GranflowInputError("yield function: expected a non-empty expression in phi and I")
    if any(tok in text for tok in ("__", "lambda", "import", ";")):
        raise GranflowInputError(f"yield function {_text(text)}: forbidden token")
    local = {"phi": phi, "I": I, **_ALLOWED_FUNCTIONS}
    try:
        expr = parse_expr(
            text,
            local_dict=local,
            global_dict={"Integer": sp.Integer, "Float": sp.Float, "Symbol": sp.Symbol, "Rational": sp.Rational},
            transformations=standard_transformations + (implicit_multiplication_application, convert_xor),
            evaluate=True,
        )
    except Exception as err:  # SyntaxError, TokenError, TypeError, ... from the parser
        raise GranflowInputError(f"yield function {_text(text)} does not parse: {err}") from None
    if not isinstance(expr, sp.Expr):
        raise GranflowInputError(f"yield function {_text(text)} is not an expression")
    # Decimal numbers become exact rationals (0.26 -> 13/50), so that the integration constants of
    # W cancel exactly and the limits of W at I = 0 and I = inf are exact (with floats,
    # 0.117*log(0.3) - 0.140864818106135 leaves a 1e-17/I term and a spurious limit -inf).
    expr = sp.nsimplify(expr, rational=True)
    extra = expr.free_symbols - {phi, I}
    if extra:
        names = ", ".join(sorted(str(s) for s in extra))
        raise GranflowInputError(f"yield function {_text(text)}: unknown symbol(s) {names}; use phi and I only")
    if expr.has(sp.zoo, sp.oo, -sp.oo, sp.nan):
        raise GranflowInputError(f"yield function {_text(text)}: not finite (it holds {sp.zoo if expr.has(sp.zoo) else 'oo or nan'}: "
                                 "a division by zero or an infinite constant)")
    if expr.has(sp.I):
        raise GranflowInputError(f"yield function {_text(text)}: not real (it holds the imaginary unit, "
                                 "e.g. the square root of a negative constant)")
    for power in expr.atoms(sp.Pow):
        exponent = power.exp
        if power.free_symbols and exponent.is_Number and abs(exponent) > MAX_EXPONENT:
            raise GranflowInputError(f"yield function {_text(text)}: the exponent {_short(exponent)} is "
                                     f"too large (at most {MAX_EXPONENT} in magnitude)")
    for number in expr.atoms(sp.Number):
        try:
            finite = math.isfinite(float(number))
        except (OverflowError, ValueError, TypeError):
            finite = False
        if not finite:
            raise GranflowInputError(f"yield function {_text(text)}: the constant {_short(number)} is "
                                     "outside the range of double precision (|x| < 1.8e308)")
    for node in sp.preorder_traversal(expr):  # constant terms such as exp(1000) or E**1000
        if not node.free_symbols and not node.is_Number and isinstance(node, sp.Expr):
            try:
                finite = math.isfinite(float(sp.N(node)))
            except (OverflowError, ValueError, TypeError):
                finite = False
            if not finite:
                raise GranflowInputError(f"yield function {_text(text)}: the constant term "
                                         f"{_short(node)} is not finite in double precision "
                                         "(|x| < 1.8e308)")
    return expr


SINGULARITY_TIME_BUDGET_S = 10.0
"""Wall-clock budget of :func:`singular_points` [s]; beyond it no singularity is reported."""


def singular_points(Z: sp.Expr, lo: float, hi: float) -> list[float]:
    """The values of I in [lo, hi] where the yield function ``Z`` is singular (poles such as
    ``1/(I - 0.5)``, which sampling misses), as SymPy finds them; empty where it cannot tell."""
    try:
        with _time_budget(SINGULARITY_TIME_BUDGET_S, "singularities"):
            found = sp.singularities(Z, I, sp.Interval(lo, hi))
        if not isinstance(found, sp.FiniteSet):
            return []
        return sorted(float(x) for x in found if x.is_real)
    except (GranflowInputError, NotImplementedError, TypeError, ValueError, AttributeError):
        return []


class _OutOfTime(Exception):
    pass


@contextlib.contextmanager
def _time_budget(seconds: float, what: str):
    """Raise GranflowInputError if the block runs longer than ``seconds`` (main thread only)."""
    if threading.current_thread() is not threading.main_thread() or not hasattr(signal, "setitimer"):
        yield
        return

    def expire(signum, frame):
        raise _OutOfTime

    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    except _OutOfTime:
        raise GranflowInputError(f"{what}: the symbolic derivation did not finish within {seconds:g} s "
                                 "(granflow.rheology.derive.DERIVE_TIME_BUDGET_S); simplify the "
                                 "expression") from None
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def _text(text: str) -> str:
    """The expression for a one-line message (long text cut)."""
    shown = repr(text)
    return shown if len(shown) <= 80 else shown[:77] + "..."


def _short(number) -> str:
    text = str(number)
    return text if len(text) <= 30 else f"{text[:12]}...({len(text)} digits)"


@dataclass(frozen=True)
class Derivation:
    """Result of :func:`derive_dilatancy` (all SymPy expressions in ``phi``, ``I``, ``I_eq``).

    Attributes
    ----------
    Z : Expr
        The yield function Z(phi, I).
    W : Expr
        W(phi, I) of eq. f-general (with the lower bound I1 below).
    f : Expr
        The dilatancy function f(phi, I; I_eq), simplified.
    A, B : Expr
        The stiff-safe split f = A(phi, I) - B(phi; I_eq)/I, A = W, B = I_eq W(phi, I_eq).
    I1 : Expr
        Lower integration bound used for W (0 or 1).
    """

    Z: sp.Expr
    W: sp.Expr
    f: sp.Expr
    A: sp.Expr
    B: sp.Expr
    I1: sp.Expr

    def latex(self) -> str:
        return sp.latex(self.f)


def derive_dilatancy(Z: sp.Expr | str, simplify: bool = True) -> Derivation:
    """Derive f from Z by integrating C1 and imposing f(I_eq) = 0 (paper eq. f-general).

    Parameters
    ----------
    Z : sympy.Expr or str
        Yield function in the symbols ``granflow.rheology.derive.phi`` and ``.I`` (or a string,
        parsed by :func:`parse_yield_function`).
    simplify : bool
        Simplify f (default True).

    Returns
    -------
    Derivation

    Examples
    --------
    >>> from granflow.rheology.derive import derive_dilatancy, I, I_eq
    >>> import sympy as sp
    >>> d = derive_dilatancy(sp.Integer(1))
    >>> sp.simplify(d.f - (1 - I_eq / I))
    0
    """
    if isinstance(Z, str):
        Z = parse_yield_function(Z)
    Z = sp.sympify(Z)
    with _time_budget(DERIVE_TIME_BUDGET_S, f"yield function {_text(str(Z))}"):
        return _derive(Z, simplify)


def _derive(Z: sp.Expr, simplify: bool) -> Derivation:
    ZJ = Z.subs(I, _J)
    I1 = sp.Integer(0)
    try:
        integral = sp.integrate(ZJ, (_J, I1, I))
        if integral.has(sp.oo, -sp.oo, sp.zoo, sp.nan, sp.Integral) or isinstance(integral, sp.Piecewise):
            raise ValueError
    except Exception:
        I1 = sp.Integer(1)
        integral = sp.integrate(ZJ, (_J, I1, I))
    if integral.has(sp.Integral):
        raise GranflowInputError(f"cannot integrate Z = {Z} in closed form; derive f by hand")
    W = sp.Rational(3, 2) * integral / I - Z / 2
    B = I_eq * W.subs(I, I_eq)
    f = W - B / I
    if simplify:
        f = sp.simplify(f)
    return Derivation(Z=Z, W=W, f=f, A=W, B=B, I1=I1)


def c1_residual(Z: sp.Expr, f: sp.Expr) -> sp.Expr:
    """Symbolic residual of C1: Z - (I/2) dZ/dI - (f + I df/dI) (zero for a stable pair)."""
    return sp.simplify(Z - I / 2 * sp.diff(Z, I) - (f + I * sp.diff(f, I)))
