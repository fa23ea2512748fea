"""A minimal registry of interchangeable parts (closures, equilibrium laws, ...).

A TOML or CLI string such as ``closure = "mu_i"`` is a registry key; ``granflow list closures``
lists the keys. Tests loop over registries, so a part is tested the day it is registered.

Parts find themselves: :func:`discover_modules` imports every module of a package (closures in
``granflow.rheology``, cases in ``granflow.cases``) except the package's declared infrastructure
modules, so adding a part is one new file and no edit elsewhere. A package that holds parts only
(``granflow.cases``: its registry, runner and helpers are in ``granflow.casekit``) declares none,
and keeps the old import paths of the modules it gave away with :func:`alias_modules`.
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


def discover_modules(package: str, path: MutableSequence[str], infrastructure: Iterable[str] = (),
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
    infrastructure : iterable of str, optional
        Module names of the package that hold no part (base classes, helpers, ...); default none.
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


class _AliasLoader:
    """Loader of an alias: the module is the target module itself (imported on first use), so that
    ``import old.name`` and ``import new.name`` give one module object (one set of globals: a
    monkeypatch through either path is seen by both)."""

    def __init__(self, target: str) -> None:
        self.target = target
        self._spec = None

    def create_module(self, spec):
        import importlib

        module = importlib.import_module(self.target)
        self._spec = module.__spec__
        return module

    def exec_module(self, module) -> None:
        module.__spec__ = self._spec  # the import system set the alias's spec: restore the module's own


class _AliasFinder:
    """Meta-path finder of :func:`alias_modules`: ``old_package.name`` -> ``targets[name]``."""

    def __init__(self, package: str, targets: dict[str, str]) -> None:
        self.package = package
        self.targets = dict(targets)

    def find_spec(self, fullname: str, path=None, target=None):
        head, _, name = fullname.rpartition(".")
        if head != self.package or name not in self.targets:
            return None
        from importlib.machinery import ModuleSpec

        return ModuleSpec(fullname, _AliasLoader(self.targets[name]))


def alias_modules(package: str, targets: dict[str, str]) -> None:
    """Keep the old import paths of modules moved out of ``package``: ``import package.name``
    (and ``from package.name import x``, ``from package import name``) gives the module
    ``targets[name]``, imported only then. Installed once per package (a second call for the same
    package is ignored).

    ``granflow.cases`` does so for the modules it moved to ``granflow.casekit``
    (tests/unit/test_casekit_aliases.py).
    """
    import sys

    if any(isinstance(f, _AliasFinder) and f.package == package for f in sys.meta_path):
        return
    sys.meta_path.append(_AliasFinder(package, targets))
