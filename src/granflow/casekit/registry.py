"""The case registry: ``setup(config) -> Simulation`` functions keyed by name (STYLE.md idioms 2, 5;
PyClaw's ``setup()`` convention).

A case registers its setup function together with the pydantic model of its ``[setup]`` section,
a one-line summary, an optional consistency check (cross-section conditions such as
``setup.phi0 <= material.phi_max``, run at load time so that errors come before any computation)
and optional case-specific diagnostics for ``summary.json``.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from granflow.config import cases_changed, register_cases
from granflow.registry import Registry

if TYPE_CHECKING:  # pragma: no cover
    from granflow.config import CaseConfig, Section
    from granflow.simulation import Simulation

Problems = list[tuple[str, str]]
"""``[(key path, message), ...]`` returned by a case's check."""


def _no_problems(config: CaseConfig) -> Problems:
    return []


def _no_diagnostics(sim: Simulation, config: CaseConfig) -> dict[str, Any]:
    return {}


@dataclass(frozen=True)
class Case:
    """One registered case.

    Attributes
    ----------
    name : str
        Registry key (``[case] name`` in a case file).
    setup : callable
        ``setup(config) -> Simulation``: model, initial state and stop criteria from the config;
        no output (the runner attaches writers, checkpoints and progress).
    setup_model : type
        Pydantic model of the ``[setup]`` section (a :class:`granflow.config.Section`).
    summary : str
        One line for ``granflow list cases``.
    check : callable
        ``check(config) -> [(key path, message), ...]``: consistency conditions across sections.
    diagnostics : callable
        ``diagnostics(simulation, config) -> dict``: case-specific entries of ``summary.json``.
    front_threshold : callable, optional
        ``front_threshold(config) -> float``: the deposit thickness [m] that defines the front when
        ``output.front_threshold`` is not set -- a physical length, so that the run-out means the
        same at every resolution. None: one cell height.
    headline : callable, optional
        ``headline(summary) -> str``: the case's own result for the end-of-run line (a run-out, a
        Bagnold error, a half-life error, ...), from the ``summary.json`` content. None: the
        run-out.
    settles : bool
        The flow is expected to come to rest (collapses): a run that ends while still moving is
        flagged in ``summary.json`` (``still_moving``, ``warnings``) and on the console.
    units : dict
        Units of the case's lengths, times, speeds and energies when they are not SI
        (dimensionless cases): keys ``length``, ``time``, ``speed``, ``pressure``, ``rate``,
        ``energy``; the summary, output.nc,
        the console line and the figures use them.
    """

    name: str
    setup: Callable[[CaseConfig], Simulation]
    setup_model: type[Section]
    summary: str
    check: Callable[[CaseConfig], Problems] = _no_problems
    diagnostics: Callable[[Simulation, CaseConfig], dict[str, Any]] = _no_diagnostics
    front_threshold: Callable[[CaseConfig], float] | None = None
    headline: Callable[[dict[str, Any]], str] | None = None
    settles: bool = False
    units: dict[str, str] | None = None

    def unit(self, kind: str) -> str:
        """The unit of ``kind`` (``length``, ``time``, ``speed``, ``energy``) in this case."""
        return (self.units or {}).get(kind, SI_UNITS[kind])


SI_UNITS = {"length": "m", "time": "s", "speed": "m s-1", "pressure": "Pa", "rate": "s-1",
            "energy": "J m-1"}
"""Units of the dimensional cases."""


class CaseRegistry(Registry[Case]):
    """Name -> :class:`Case` (a :class:`granflow.registry.Registry` whose decorator records the
    case's options model, summary, check and diagnostics with its setup function)."""

    def __init__(self) -> None:
        super().__init__("case")

    def register(self, name: str, *, setup_model: type[Section], summary: str,  # type: ignore[override]
                 check: Callable[[CaseConfig], Problems] | None = None,
                 diagnostics: Callable[[Simulation, CaseConfig], dict[str, Any]] | None = None,
                 front_threshold: Callable[[CaseConfig], float] | None = None,
                 headline: Callable[[dict[str, Any]], str] | None = None, settles: bool = False,
                 units: dict[str, str] | None = None,
                 ) -> Callable[[Callable[[CaseConfig], Simulation]], Callable[[CaseConfig], Simulation]]:
        """Decorator registering ``setup`` as the case ``name``."""

        def deco(setup: Callable[[CaseConfig], Simulation]) -> Callable[[CaseConfig], Simulation]:
            self.add(name, Case(name, setup, setup_model, summary, check or _no_problems,
                                diagnostics or _no_diagnostics, front_threshold, headline, settles,
                                units))
            cases_changed()
            return setup

        return deco

    def unregister(self, name: str) -> None:
        """Remove a case (for cases registered by tests)."""
        self.remove(name)
        cases_changed()


CASES = CaseRegistry()
"""The registry of cases (``granflow list cases``); the case catalogue of :mod:`granflow.config`."""
register_cases(CASES)
