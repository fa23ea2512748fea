"""Register the ``ds.granflow`` accessor without importing xarray (issue 15: start-up of a run).

:mod:`granflow.output.accessor` registers the accessor when it is imported, and it imports
xarray, which imports pandas: 0.3-0.5 s of every ``granflow run`` that writes with netCDF4 and
never opens a Dataset. So :mod:`granflow.output` calls :func:`register_accessor_when_xarray_imported`
instead of importing the accessor:

* xarray already in ``sys.modules``: the accessor module is imported (registered) at once;
* otherwise a one-shot finder, :class:`XarrayImportHook`, is put at the head of
  ``sys.meta_path``. It answers for the name ``xarray`` only (every other import is passed on
  with one string comparison), removes itself, finds xarray's real spec with the other finders
  and wraps its loader so that, right after xarray's own module has run, the accessor module is
  imported. ``import xarray`` then returns an xarray with ``Dataset.granflow`` registered; the
  module's ``__loader__`` and ``__spec__.loader`` are xarray's own again before its code runs.

So ``import granflow.output`` (or anything that imports it, such as
:mod:`granflow.casekit.runner`) followed, in either order, by ``import xarray`` gives
``ds.granflow``, as it did when the accessor was imported eagerly. A failure to register (an
xarray too old or too new for the accessor) is a warning, never a failed ``import xarray``.
"""
from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys
import warnings

XARRAY = "xarray"
ACCESSOR_MODULE = "granflow.output.accessor"


def register_accessor() -> None:
    """Import the accessor module (which registers ``ds.granflow``); a warning if it fails."""
    try:
        importlib.import_module(ACCESSOR_MODULE)
    except Exception as err:  # noqa: BLE001 - registering must never break `import xarray`
        warnings.warn(f"granflow: the ds.granflow xarray accessor was not registered: {err!r}",
                      RuntimeWarning, stacklevel=2)


class _RegisteringLoader(importlib.abc.Loader):
    """Wraps xarray's loader: runs it, then registers the accessor."""

    def __init__(self, loader) -> None:
        self.loader = loader

    def create_module(self, spec):
        return self.loader.create_module(spec)

    def exec_module(self, module) -> None:
        module.__loader__ = self.loader  # xarray's own loader while and after its code runs
        if module.__spec__ is not None:
            module.__spec__.loader = self.loader
        self.loader.exec_module(module)
        register_accessor()


class XarrayImportHook(importlib.abc.MetaPathFinder):
    """One-shot ``sys.meta_path`` finder: registers the accessor after xarray is imported."""

    def find_spec(self, fullname, path=None, target=None):
        if fullname != XARRAY:
            return None
        remove_hook()  # one shot; and importlib.util.find_spec below must not come back here
        spec = importlib.util.find_spec(XARRAY)
        if spec is None or spec.loader is None or not hasattr(spec.loader, "exec_module"):
            return spec
        spec.loader = _RegisteringLoader(spec.loader)
        return spec


def installed_hooks() -> list[XarrayImportHook]:
    """The hooks now in ``sys.meta_path`` (none or one)."""
    return [f for f in sys.meta_path if isinstance(f, XarrayImportHook)]


def remove_hook() -> None:
    """Take the hook out of ``sys.meta_path`` (no-op when it is not there)."""
    for hook in installed_hooks():
        try:
            sys.meta_path.remove(hook)
        except ValueError:  # pragma: no cover - removed by another thread meanwhile
            pass


def register_accessor_when_xarray_imported() -> None:
    """Register ``ds.granflow`` now if xarray is imported, else when it is (see the module)."""
    if XARRAY in sys.modules:
        register_accessor()
    elif not installed_hooks():
        sys.meta_path.insert(0, XarrayImportHook())
