"""The ``ds.granflow`` xarray accessor: deposit thickness, front position, run-out, snapshots.

Importing :mod:`granflow.output` registers the accessor. The diagnostics follow NUMERICS.md §10:
the deposit thickness is h(x) = sum_j phi(x, z_j) dz_j / phi_max (the height the grains would occupy
at random close packing) and the front x_f is the right edge of the furthest column where h exceeds a
threshold (by default the run's own, the ``front_threshold_m`` attribute that ``granflow run``
writes, else one cell height): the one definition of :func:`granflow.diagnostics.front_from_thickness`,
the same as the run's ``x_front`` and ``summary.json``. Column edges come from CF bounds when ``x``
has a ``bounds`` attribute, otherwise ``x`` must be uniformly spaced. The dataset must hold a packing-fraction variable ``phi`` with dimensions
``time``, ``x``, ``z`` (any order), a ``phi_max`` attribute on ``phi`` or on the dataset, and
coordinates ``x`` and ``z`` in metres. Cell heights come from CF cell bounds when the ``z``
coordinate has a ``bounds`` attribute, otherwise ``z`` must be uniformly spaced.

Examples
--------
>>> import numpy as np, xarray as xr, granflow.output
>>> x = np.arange(4) * 0.1 + 0.05; z = np.arange(2) * 0.01 + 0.005
>>> phi = np.zeros((2, 4, 2)); phi[0, :1] = 0.6; phi[1, :3] = 0.6
>>> ds = xr.Dataset({"phi": (("time", "x", "z"), phi, {"phi_max": 0.6})},
...                 coords={"time": [0.0, 1.0], "x": x, "z": z})
>>> ds.granflow.front_position().values.round(3).tolist()
[0.1, 0.3]
>>> round(float(ds.granflow.runout()), 3)
0.2
"""
from __future__ import annotations

import enum
from typing import Any

import numpy as np
import xarray as xr

from granflow import diagnostics as dg
from granflow.errors import GranflowInputError
from granflow.output.netcdf import TIME_DIM

#: Names the solver's output must use.
PHI_VAR = "phi"
X_DIM = "x"
Z_DIM = "z"
PHI_MAX_ATTR = "phi_max"
RUN_THRESHOLD_ATTR = "front_threshold_m"
"""Global attribute in which ``granflow run`` records its front threshold [m]."""
#: Relative tolerance on the spacing of ``z`` for it to count as uniform.
UNIFORM_RTOL = 1e-6
#: Number of values per cell in a CF bounds variable.
N_BOUNDS = 2
LENGTH_UNITS = "m"


class FrontMethod(str, enum.Enum):
    """How the front is located (:func:`granflow.diagnostics.front_from_thickness`)."""

    #: The front: the right edge of the furthest column with h > threshold (resolution dx).
    EDGE = dg.FRONT_EDGE
    #: Sub-cell estimate: linear interpolation of h between that column's centre and the next.
    LINEAR = dg.FRONT_LINEAR


class Direction(str, enum.Enum):
    """Direction in which the flow spreads (where "furthest" is measured)."""

    PLUS_X = "+x"
    MINUS_X = "-x"


@xr.register_dataset_accessor("granflow")
class GranflowAccessor:
    """Diagnostics of granflow output, available as ``ds.granflow`` on any xarray Dataset."""

    def __init__(self, ds: xr.Dataset) -> None:
        self._ds = ds

    # ------------------------------------------------------------------ helpers
    def _phi(self) -> xr.DataArray:
        if PHI_VAR not in self._ds:
            raise GranflowInputError(f"dataset has no {PHI_VAR!r} (packing fraction) variable")
        phi = self._ds[PHI_VAR]
        missing = [d for d in (X_DIM, Z_DIM) if d not in phi.dims]
        if missing:
            raise GranflowInputError(f"variable {PHI_VAR!r} lacks dimension(s) {missing}; "
                                     f"has {phi.dims}")
        return phi

    def phi_max(self) -> float:
        """Random-close-packing fraction: attribute ``phi_max`` of ``phi``, else of the dataset."""
        phi = self._phi()
        value = phi.attrs.get(PHI_MAX_ATTR, self._ds.attrs.get(PHI_MAX_ATTR))
        if value is None:
            raise GranflowInputError(f"no {PHI_MAX_ATTR!r} attribute on {PHI_VAR!r} or the dataset")
        value = float(value)
        if not value > 0.0:
            raise GranflowInputError(f"{PHI_MAX_ATTR} must be > 0, got {value}")
        return value

    def cell_heights(self) -> xr.DataArray:
        """Cell heights dz(z) [m], from the CF ``bounds`` of ``z`` or its uniform spacing."""
        if Z_DIM not in self._ds.coords:
            raise GranflowInputError(f"dataset has no {Z_DIM!r} coordinate")
        z = self._ds[Z_DIM]
        bounds_name = z.attrs.get("bounds")
        if bounds_name is not None:
            if bounds_name not in self._ds:
                raise GranflowInputError(f"{Z_DIM}.bounds names {bounds_name!r}, not in the dataset")
            b = np.asarray(self._ds[bounds_name].values, dtype=float)
            if b.shape != (z.size, N_BOUNDS):
                raise GranflowInputError(f"{bounds_name!r}: shape {b.shape}, expected "
                                         f"({z.size}, {N_BOUNDS})")
            dz = np.abs(b[:, 1] - b[:, 0])
        else:
            zv = np.asarray(z.values, dtype=float)
            if zv.size < N_BOUNDS:
                raise GranflowInputError(f"cannot infer the cell height from a single {Z_DIM} "
                                         "value; give CF bounds")
            spacing = np.diff(zv)
            step = (zv[-1] - zv[0]) / (zv.size - 1)
            if not np.allclose(spacing, step, rtol=UNIFORM_RTOL, atol=0.0):
                raise GranflowInputError(f"{Z_DIM} is not uniformly spaced; give CF bounds "
                                         f"(attribute 'bounds' on {Z_DIM})")
            dz = np.full(zv.size, abs(step))
        return xr.DataArray(dz, dims=(Z_DIM,), coords={Z_DIM: z},
                            attrs={"units": LENGTH_UNITS, "long_name": "cell height"})

    def column_edges(self) -> np.ndarray:
        """Edges of the columns along x [m], increasing (nx + 1,), from the CF ``bounds`` of ``x``
        or its uniform spacing."""
        if X_DIM not in self._ds.coords:
            raise GranflowInputError(f"dataset has no {X_DIM!r} coordinate")
        x = self._ds[X_DIM]
        bounds_name = x.attrs.get("bounds")
        xv = np.asarray(x.values, dtype=float)
        if bounds_name is not None and bounds_name in self._ds:
            b = np.sort(np.asarray(self._ds[bounds_name].values, dtype=float), axis=1)
            b = b[np.argsort(xv, kind="stable")]
            return np.concatenate([b[:, 0], b[-1:, 1]])
        if xv.size < N_BOUNDS:
            raise GranflowInputError(f"cannot infer the column width from a single {X_DIM} value; "
                                     "give CF bounds")
        xs = np.sort(xv)
        step = (xs[-1] - xs[0]) / (xs.size - 1)
        if not np.allclose(np.diff(xs), step, rtol=UNIFORM_RTOL, atol=0.0):
            raise GranflowInputError(f"{X_DIM} is not uniformly spaced; give CF bounds "
                                     f"(attribute 'bounds' on {X_DIM})")
        return np.concatenate([xs - 0.5 * step, xs[-1:] + 0.5 * step])

    def _threshold(self, threshold: float | None) -> float:
        if threshold is None:  # the run's own threshold (granflow run writes it), else one cell
            stored = self._ds.attrs.get(RUN_THRESHOLD_ATTR)
            return float(stored) if stored is not None else float(self.cell_heights().max())
        threshold = float(threshold)
        if not threshold >= 0.0:
            raise GranflowInputError(f"front threshold must be >= 0 m, got {threshold}")
        return threshold

    # ------------------------------------------------------------------ diagnostics
    def deposit_thickness(self, t: float | None = None) -> xr.DataArray:
        """Deposit thickness h(x) = sum_z phi dz / phi_max [m] (NUMERICS.md §10).

        Parameters
        ----------
        t : float, optional
            Time [s]; the nearest output time is used. ``None``: all times.

        Returns
        -------
        xarray.DataArray
            Over (time, x), or over x when ``t`` is given. NaN in ``phi`` propagates.
        """
        phi = self._phi()
        if t is not None:
            phi = self._nearest(phi, t)
        h = (phi * self.cell_heights()).sum(Z_DIM, skipna=False) / self.phi_max()
        h.name = "h"
        h.attrs = {"units": LENGTH_UNITS,
                   "long_name": "deposit thickness (sum over z of phi dz / phi_max)"}
        return h

    def front_position(self, threshold: float | None = None,
                       method: FrontMethod | str = FrontMethod.EDGE,
                       direction: Direction | str = Direction.PLUS_X) -> xr.DataArray:
        """Front position x_f(t): the right edge of the furthest column where h(x) > ``threshold``
        (:func:`granflow.diagnostics.front_from_thickness`, the run's own definition).

        Parameters
        ----------
        threshold : float, optional
            Thickness threshold [m]; default the run's (attribute ``front_threshold_m``), else one
            cell height (the largest, if cells differ).
        method : {"edge", "linear"}
            ``"edge"``: the front (resolution one column width dx). ``"linear"``: sub-cell
            estimate, where the linear interpolant of h between the centres of that column and
            the next equals the threshold (exact for a deposit whose thickness is linear there).
        direction : {"+x", "-x"}
            ``"+x"``: largest such x; ``"-x"``: smallest (flow spreading towards -x; the left
            edge of the furthest column).

        Returns
        -------
        xarray.DataArray
            x_f over time [units of x, m]; NaN where no column exceeds the threshold.
        """
        method, direction = FrontMethod(method), Direction(direction)
        h = self.deposit_thickness()
        thr = self._threshold(threshold)
        scalar_time = TIME_DIM not in h.dims
        if scalar_time:
            h = h.expand_dims(TIME_DIM)
        h = h.transpose(TIME_DIM, X_DIM)
        x = np.asarray(h[X_DIM].values, dtype=float)
        order = np.argsort(x, kind="stable")
        edges = self.column_edges()
        hv = np.asarray(h.values, dtype=float)[:, order]
        if direction is Direction.MINUS_X:  # mirror: the same rule along -x
            front = -dg.front_from_thickness(-edges[::-1], hv[:, ::-1], thr, method.value)
        else:
            front = dg.front_from_thickness(edges, hv, thr, method.value)
        out = xr.DataArray(np.atleast_1d(front), dims=(TIME_DIM,), coords={TIME_DIM: h[TIME_DIM]},
                           name="x_f",
                           attrs={"units": self._ds[X_DIM].attrs.get("units", LENGTH_UNITS),
                                  "long_name": f"front position (h > {thr:g} m, {method.value})",
                                  "definition": dg.FRONT_DEFINITION,
                                  "resolution": float(np.max(np.diff(edges)))})
        return out.isel({TIME_DIM: 0}) if scalar_time else out

    def runout(self, threshold: float | None = None, method: FrontMethod | str = FrontMethod.EDGE,
               direction: Direction | str = Direction.PLUS_X) -> xr.DataArray:
        """Run-out distance Delta L = x_f(t_last) - x_f(t_first) [m].

        The distance the front has travelled between the first and the last output time, with
        :meth:`front_position` and the same arguments (for ``direction="-x"`` the sign is flipped
        so that spreading gives a positive run-out). Normalise by the initial column length L0
        yourself for Delta L / L0. The front at the *last* time is used, not its maximum over time.

        Returns
        -------
        xarray.DataArray
            0-d, with ``units``; ``float(ds.granflow.runout())`` gives the number.
        """
        xf = self.front_position(threshold, method, direction)
        if TIME_DIM not in xf.dims or xf.sizes[TIME_DIM] == 0:
            raise GranflowInputError("run-out needs a time series of phi")
        sign = -1.0 if Direction(direction) is Direction.MINUS_X else 1.0
        out = sign * (xf.isel({TIME_DIM: -1}, drop=True) - xf.isel({TIME_DIM: 0}, drop=True))
        out.name = "runout"
        out.attrs = {"units": xf.attrs["units"],
                     "long_name": "run-out distance x_f(t_last) - x_f(t_first)"}
        return out

    @staticmethod
    def _nearest(obj: Any, t: float) -> Any:
        if TIME_DIM not in obj.dims:
            raise GranflowInputError(f"no {TIME_DIM!r} dimension to select from")
        return obj.sel({TIME_DIM: float(t)}, method="nearest")

    def snapshot(self, t: float) -> xr.Dataset:
        """The dataset at the output time nearest to ``t`` [s]."""
        return self._nearest(self._ds, t)
