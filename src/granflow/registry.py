"""A minimal registry of interchangeable parts (closures, equilibrium laws, ...).

A TOML or CLI string such as ``closure = "mu_i"`` is a registry key; ``granflow list closures``
lists the keys. Tests loop over registries, so a part is tested the day it is registered.

Parts find themselves: :func:`discover_modules` imports every module of a package (closures in
``granflow.rheology``, cases in ``granflow.cases``) except the package's declared infrastructure
modules, so adding a part is one new file and no edit elsewhere.
"""
from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, MutableSequence
from typing import Generic, TypeVar

from granflow.errors import UnknownNameError

T = TypeVar("T")


class Registry(Generic[T]):
    """Name -> part mapping (classes, or records such as cases) with helpful errors.

    Parameters
    ----------
    kind : str
        What the registry holds, used in error messages (e.g. ``"closure"``).
    """

    def __init__(self, kind: str) -> None:
        self.kind = kind
        self._items: dict[str, type[T]] = {}

    def register(self, name: str) -> Callable[[type[T]], type[T]]:
        """Class decorator registering ``cls`` under ``name`` (sets ``cls.name``)."""

        def deco(cls: type[T]) -> type[T]:
            self.add(name, cls)
            cls.name = name  # type: ignore[attr-defined]
            return cls

        return deco

    def add(self, name: str, item) -> None:
        """Register ``item`` under ``name``; a name can be registered once."""
        if name in self._items:
            raise ValueError(f"{self.kind} {name!r} is already registered")
        self._items[name] = item

    def remove(self, name: str) -> None:
        """Forget ``name`` (no error if absent); for parts registered by tests."""
        self._items.pop(name, None)

    def get(self, name: str) -> type[T]:
        """Return the part registered as ``name``; unknown names raise :class:`UnknownNameError`."""
        try:
            return self._items[name]
        except KeyError:
            raise UnknownNameError(
                f"unknown {self.kind} {name!r}; expected one of: {', '.join(self.names())}"
            ) from None

    def names(self) -> list[str]:
        """Registered names, sorted."""
        return sorted(self._items)

    def __contains__(self, name: object) -> bool:
        return name in self._items

    def __iter__(self) -> Iterator[str]:
        return iter(self.names())

    def __len__(self) -> int:
        return len(self._items)


def discover_modules(package: str, path: MutableSequence[str], infrastructure: Iterable[str],
                     paths: Iterable[str] = ()) -> list[str]:
    """Import the part modules of ``package``: every module found on its ``path`` that is neither
    private (``_name``) nor listed in ``infrastructure``; importing a part module registers its
    parts.

    Parameters
    ----------
    package : str
        Dotted package name (``"granflow.rheology"``).
    path : list of str
        The package's ``__path__``.
    infrastructure : iterable of str
        Module names of the package that hold no part (base classes, helpers, the runner, ...).
    paths : iterable of str, optional
        Extra directories, appended to ``path``: their modules become modules of ``package``
        (``package.<name>``) and are imported by the same rule -- the hook for parts kept outside
        the source tree (and for the tests).

    Returns
    -------
    list of str
        Full names of the part modules, sorted (already imported ones included).
    """
    import pkgutil  # here, not at module level: only the registries that discover need it

    for extra in paths:
        if extra not in path:
            path.append(str(extra))
    skip = set(infrastructure)
    names = sorted(f"{package}.{info.name}" for info in pkgutil.iter_modules(list(path))
                   if not info.name.startswith("_") and info.name not in skip)
    for name in names:
        __import__(name)  # not importlib.import_module: ``python -X importtime`` times this one
    return names
