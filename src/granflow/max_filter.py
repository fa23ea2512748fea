"""A NumPy ``maximum_filter``: the subset of :func:`scipy.ndimage.maximum_filter` the solver uses
(issue 15: start-up of a run).

Importing :mod:`scipy.ndimage` costs 0.1-0.17 s of CPU on the 2-core development machine (its
array-API wrappers parse some 170 docstrings at import), on every run, for one function. This one
gives the same values for what :mod:`granflow.model_fields` calls it with: a square window of odd
``size`` centred on each element (``origin = 0``), boundary modes ``"nearest"``, ``"wrap"`` and
``"constant"`` (with ``cval = 0``: ``False`` for masks), one per axis or one for all, any
dimension, boolean or float arrays. The maximum of a set does not depend on the order in which it
is taken, so the values are those of SciPy (tested against it), NaN aside (NumPy's maximum
propagates NaN, SciPy's comparisons may not).

Cost: one pad and O(log size) :func:`numpy.maximum` passes per axis (the running maximum over
windows of 1, 2, 4, ... elements), about SciPy's time for the sizes used (3 to 21).
"""
from __future__ import annotations

import numpy as np

#: ``scipy.ndimage`` boundary mode -> :func:`numpy.pad` mode (``constant`` pads zeros).
PAD_MODES = {"nearest": "edge", "wrap": "wrap", "constant": "constant"}


def maximum_filter(a, size: int, mode: str | tuple[str, ...] = "nearest") -> np.ndarray:
    """Maximum of ``a`` over the ``size``-wide window centred on each element, along every axis.

    Parameters
    ----------
    a : array_like
        Boolean or numeric array, any dimension.
    size : int
        Window width, odd and >= 1 (the same along every axis).
    mode : str or tuple of str
        ``"nearest"``, ``"wrap"`` or ``"constant"`` (zero), for all axes or one per axis.

    Returns
    -------
    numpy.ndarray
        Same shape and dtype as ``a``.

    Examples
    --------
    >>> maximum_filter(np.array([[0, 1, 0, 0, 0]]), 3, mode=("nearest", "constant")).tolist()
    [[1, 1, 1, 0, 0]]
    >>> maximum_filter(np.array([[0, 0, 0, 0, 2]]), 3, mode=("nearest", "wrap")).tolist()
    [[2, 0, 0, 2, 2]]
    """
    a = np.asarray(a)
    if size < 1 or size % 2 != 1:
        raise ValueError(f"size must be odd and >= 1, got {size}")
    modes = (mode,) * a.ndim if isinstance(mode, str) else tuple(mode)
    if len(modes) != a.ndim or any(m not in PAD_MODES for m in modes):
        raise ValueError(f"mode must be one of {sorted(PAD_MODES)} or one per axis, got {mode!r}")
    out = a.copy()
    for axis, m in enumerate(modes):
        out = _running_max(out, size, axis, PAD_MODES[m])
    return out


def _slice(a: np.ndarray, axis: int, start: int, stop: int) -> np.ndarray:
    index = [slice(None)] * a.ndim
    index[axis] = slice(start, stop)
    return a[tuple(index)]


def _running_max(a: np.ndarray, size: int, axis: int, pad_mode: str) -> np.ndarray:
    """Centred running maximum of width ``size`` along ``axis``."""
    if size == 1:
        return a
    n, r = a.shape[axis], size // 2
    width = [(0, 0)] * a.ndim
    width[axis] = (r, r)
    m = np.pad(a, width, mode=pad_mode)  # m[i] = max of the padded array over [i, i + w)
    w = 1
    while 2 * w <= size:
        length = m.shape[axis]
        m = np.maximum(_slice(m, axis, 0, length - w), _slice(m, axis, w, length))
        w *= 2
    # the window [i, i + size) is covered by [i, i + w) and [i + size - w, i + size)
    return np.maximum(_slice(m, axis, 0, n), _slice(m, axis, size - w, size - w + n))
