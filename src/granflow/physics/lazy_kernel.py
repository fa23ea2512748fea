"""A compiled (Numba) function imported on first use, so that ``import granflow`` does not import
Numba, with a once-asked availability check for the NumPy fallback (the pattern of
:mod:`granflow.physics.transport_kernel` and :mod:`granflow.physics.material_kernel`; the njit
functions live at module level in their own modules so that ``cache=True`` can store them)."""
from __future__ import annotations

import importlib
from typing import Callable


class LazyKernel:
    """The function ``name`` of the module ``module``, imported by :meth:`get` on first use."""

    def __init__(self, module: str, name: str) -> None:
        self.module, self.name = module, name
        self._function: Callable | None = None
        self._available: bool | None = None

    def get(self) -> Callable:
        """The compiled function (loaded from Numba's cache after the first run); ImportError
        without Numba."""
        if self._function is None:
            self._function = getattr(importlib.import_module(self.module), self.name)
        return self._function

    def available(self) -> bool:
        """True if the module (and so Numba) imports; asked once."""
        if self._available is None:
            try:
                self.get()
                self._available = True
            except ImportError:
                self._available = False
        return self._available
