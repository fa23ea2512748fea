"""The velocity unknowns and pressure cells of a step, and the pattern kept across steps.

* :func:`step_region` -- the region solved in a step (the velocity band of
  ``numerics.ambient.velocity_band`` cells around the grains, :meth:`granflow.model.Model.
  velocity_region`), built ``velocity_band_margin`` cells wider and kept on the model while it
  still covers the band, so that the saddle system keeps its sparsity pattern and PARDISO its
  analysis (docs/solver.md, "Keeping the pattern");
* :func:`band_edge` -- the stress-free edge of the band (indicator surface);
* :func:`region_payload` / :func:`restore_region` -- what a checkpoint stores of the kept region
  (two masks), so that a restart takes its next steps exactly as the continued run does.

Knows nothing of cases, output or the CLI.
"""

from __future__ import annotations

from typing import Any, Mapping

import numpy as np

from granflow.errors import GranflowInputError
from granflow.max_filter import maximum_filter
from granflow.model_options import PHI_STRANDED, PHI_TRACE, STRANDED_VOLUME

REGION_KEYS = ("model.region.velocity", "model.region.pressure")
"""Checkpoint entries of the kept region: the velocity unknowns (n_unknowns,) and the pressure
cells (n_cells,), boolean masks."""
KEPT_ENTRIES = 4
"""Entries of the kept region that :func:`step_region` returns (``model.region_cache`` holds one
more: the cells its band covers, :func:`band_cover`)."""


def band_edge(ops, keep) -> tuple:
    """Masks of the cells (n_cells,) and nodes (n_nodes,) whose strain rate involves a velocity
    unknown outside the band ``keep`` (``ec``/``en`` of :mod:`granflow.operators`; ``ops`` the
    Operators or the pair ``(|ec|, |en|)``, :attr:`granflow.model.Model.strain_stencils`). Their viscosity
    is set to 0, so that the band's edge is stress-free: the ambient beyond the band is not a wall
    at rest that the material would drag through the ambient viscosity (with ``u = 0`` there and
    ``eta_a`` = 1e-3 Pa s, a 1 cm mu(I) layer at 22 deg released from rest ran 2.7 % (40 cells
    over h) to 5.6 % (80 cells) under Bagnold's u_s, the stress eta_a u_s / (band dz) growing as
    1/dz; stress-free: +0.4 %, as with the band off). Conservative: ``V`` keeps the form
    ``ec^T diag(eta_c) ec + en^T diag(w eta_n) en`` with fewer terms, so the dissipation identity
    holds."""
    out = (~np.asarray(keep, dtype=bool)).astype(float)
    ec, en = ops if isinstance(ops, tuple) else (abs(ops.ec), abs(ops.en))
    return (ec @ out > 0.0), (en @ out > 0.0)


def step_region(model, phi, dense, never_active=None) -> tuple:
    """``(keep, region, band edge, pressure cells)`` of a step: the velocity unknowns
    (:meth:`granflow.model.Model.velocity_region`), their assembly gathers, the stress-free band
    edge (:func:`band_edge`, indicator surface) and the cells whose p is an unknown (None: the
    dense cells). With ``numerics.ambient.velocity_band_margin = m > 0`` they are built ``m``
    cells wider (the pressure cells: every cell within ``m`` cells of grains or of dense cells:
    with the indicator surface a trace of material, ``c > C_MIN`` but ``phi`` under the grains'
    threshold, is dense but no grain: counted from grains only, the Lagree column at 256² rebuilt
    its region in 231 of 559 steps, 167 times for such a trace one cell outside)
    and kept on the model (``model.region_cache``) for the next steps while the band of
    ``velocity_band`` cells and the dense cells stay inside them, so that the saddle system keeps
    its pattern (and PARDISO its analysis); :meth:`granflow.model.Model.forget_caches` drops them,
    :func:`region_payload` saves them in checkpoints. ``never_active``: the dense cells that get
    no row this step (:func:`granflow.active_set.never_active`), the only dense cells that may be
    left outside the kept pressure cells (:func:`_still_covers`)."""
    margin = model.ambient.velocity_band_margin
    cache = model.region_cache
    if margin and cache is not None and _still_covers(model, cache, phi, dense, never_active):
        return cache[:KEPT_ENTRIES]
    keep = model.velocity_region(phi)
    if keep is None or not margin or model.velocity_band is None:
        region = None if keep is None else model.assembler.region(keep)
        edge = None if keep is None or not model.indicator else band_edge(model.strain_stencils, keep)
        return keep, region, edge, None
    if cache is None or np.any(keep & ~cache[0]) or np.any(dense & ~cache[3]):
        wide = model.velocity_region(phi, band=model.velocity_band + margin)
        if wide is None:  # the wider band covers the grid: solve everywhere, nothing to keep
            return None, None, None, None
        cache = model.region_cache = _kept(model, wide, model.grain_cells(phi, margin, dense))
    return cache[:KEPT_ENTRIES]


def _still_covers(model, cache: tuple, phi, dense, never_active=None) -> bool:
    """True if the kept region still holds this step's band and dense cells: the grains lie in
    the cells its band covers (``cache[KEPT_ENTRIES]``, :func:`band_cover`) and the dense cells in
    its pressure cells. Equivalent to ``keep <= wide`` with ``keep`` =
    :meth:`~granflow.model.Model.velocity_region` (``phi``), without its window maximum over
    ``2 velocity_band + 1`` cells (a 2.6 ms step of 256^2 on the development machine); None
    (a topography, whose open faces change ``keep``) means: not known, build ``keep``.

    Isolated traces outside it (:func:`_stranded`, ``phi < PHI_STRANDED phi_max``) do not count:
    they keep the faces the kept region gives them, at rest beyond it, until a rebuild; a dense
    one only if it gets no row this step (``never_active``: a dense cell with a row must be a
    pressure unknown). The Lagree column (a = 1.42, 256^2, one solve per step, margin 3, to
    t = 4) rebuilt its region 122 times in 553 steps, nearly all for single-cell traces of phi
    ~1e-6..3e-4 carried by the ambient one cell a step; with them stranded, 22 times (user CPU
    17.5 -> 16.1 s, two pairs; fronts at t = 1..4 unchanged, phi differs by 1e-3 in L1)."""
    cover = cache[KEPT_ENTRIES]
    if cover is None:
        return False
    phi = np.asarray(phi, dtype=float).ravel()
    grains = phi > PHI_TRACE * model.material.phi_max
    if not grains.any():
        return False
    dense_out = dense & ~cache[3]
    if dense_out.any() and (never_active is None or np.any(dense_out & ~never_active)):
        return False
    out = np.flatnonzero((grains & ~cover) | dense_out)
    if out.size == 0:
        return True
    if phi[out].sum() > STRANDED_VOLUME * phi.sum():  # not a trace: a dilute cloud
        return False
    return _stranded(model.grid.cell_shape, phi, out, PHI_STRANDED * model.material.phi_max, model.grid.periodic_x)


def _stranded(shape: tuple, phi: np.ndarray, cells: np.ndarray, limit: float, periodic_x: bool = False) -> bool:
    """True if every cell of ``cells`` (flat indices) and its eight neighbours hold ``phi <
    limit``: isolated traces, left at rest outside the kept region (:data:`~granflow.
    model_options.PHI_STRANDED`), not the thin tip of a front (next to a fuller cell). A periodic
    x boundary wraps."""
    i, k = np.unravel_index(cells, shape)
    for di in (-1, 0, 1):
        for dk in (-1, 0, 1):
            ii, kk = i + di, k + dk
            if periodic_x:
                ii = ii % shape[0]
            inside = (ii >= 0) & (ii < shape[0]) & (kk >= 0) & (kk < shape[1])
            if np.any(phi[np.ravel_multi_index((ii[inside], kk[inside]), shape)] >= limit):
                return False
    return True


def band_cover(model, wide: np.ndarray) -> np.ndarray | None:
    """Flat mask of the cells whose band lies in the velocity unknowns ``wide``: the cells ``g``
    such that every face of every cell within ``velocity_band`` cells of ``g`` is in ``wide``
    (:meth:`~granflow.model.Model.velocity_region` keeps exactly those faces of a grain ``g``), so
    that ``velocity_region(phi) <= wide`` if and only if every grain is in the mask. None with a
    topography (its closed faces are dropped from the band) or without a band."""
    if model.ops.open_faces is not None or model.velocity_band is None:
        return None
    shape = model.grid.cell_shape
    outside = (model._face_cells.T @ (~np.asarray(wide, dtype=bool)).astype(float)) > 0.0
    mode = ("wrap", "constant") if model.grid.periodic_x else "constant"
    reach = maximum_filter(outside.reshape(shape), size=2 * model.velocity_band + 1, mode=mode)
    return ~reach.ravel()


def _kept(model, wide: np.ndarray, cells: np.ndarray) -> tuple:
    """The cached tuple of :func:`step_region` from its two masks (all else derives from them)."""
    edge = None if not model.indicator else band_edge(model.strain_stencils, wide)
    return wide, model.assembler.region(wide), edge, cells, band_cover(model, wide)


def region_payload(model) -> dict[str, np.ndarray]:
    """Checkpoint arrays of the kept region (:data:`REGION_KEYS`; empty when nothing is kept)."""
    cache = model.region_cache
    return {} if cache is None else dict(zip(REGION_KEYS, (cache[0], cache[3])))


def restore_region(model, arrays: Mapping[str, Any]) -> None:
    """Keep the region of a checkpoint's :func:`region_payload`, as the run that wrote it did.

    Nothing is kept if the checkpoint has none or the model keeps none
    (``velocity_band_margin = 0``, no band): the next step builds its region afresh.

    Raises
    ------
    GranflowInputError
        If a mask is not boolean or does not fit the model's grid.
    """
    model.region_cache = None
    if not all(k in arrays for k in REGION_KEYS) or not model.ambient.velocity_band_margin \
            or model.velocity_band is None:
        return
    masks = [np.asarray(arrays[k]) for k in REGION_KEYS]
    sizes = (model.grid.n_unknowns, model.grid.n_cells)
    for key, mask, size in zip(REGION_KEYS, masks, sizes):
        if mask.dtype != bool or mask.shape != (size,):
            raise GranflowInputError(f"checkpoint: {key} is a {mask.dtype} array of shape {mask.shape}, "
                                     f"not a boolean mask of shape ({size},)")
    model.region_cache = _kept(model, *masks)
