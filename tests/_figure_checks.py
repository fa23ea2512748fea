"""What a referee checks first in a figure, on matplotlib Figure objects (Agg): every drawn axis
has a label, no two tick labels overlap ("0.00.010.0203"), the plotted data lie within the axis
limits, and every text (labels, titles, notes) lies inside the figure. Written independently of
:mod:`granflow.plotting`'s own tick thinning, which it checks."""
from __future__ import annotations

import numpy as np

GAP_PX = 1.0
"""Tick labels closer than this [px] count as overlapping."""
EDGE_PX = 1.0
"""Texts may reach this far [px] beyond the figure's edge (antialiasing)."""
LIMIT_TOL = 1e-9
"""Relative tolerance of the data-within-limits check."""


def _renderer(fig):
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = FigureCanvasAgg(fig)  # the figure may have been closed by pyplot after savefig
    canvas.draw()
    return canvas.get_renderer()


def _ticks_in_view(axis) -> list[list]:
    lo, hi = sorted(axis.get_view_interval())
    tol = LIMIT_TOL * (hi - lo)
    locs = list(axis.get_majorticklocs())
    ticks = axis.get_major_ticks(len(locs))
    sides = []
    for side in ("label1", "label2"):
        sides.append([getattr(t, side) for t, loc in zip(ticks, locs)
                      if lo - tol <= loc <= hi + tol and getattr(t, side).get_visible()
                      and getattr(t, side).get_text()])
    return sides


def _shows_ticks(axis) -> bool:
    return axis.get_visible() and any(_ticks_in_view(axis))


def _inside(lo, hi, values) -> bool:
    values = np.asarray(values, dtype=float)
    values = values[np.isfinite(values)]
    if values.size == 0:
        return True
    lo, hi = sorted((lo, hi))
    tol = LIMIT_TOL * max(abs(hi - lo), abs(hi), abs(lo))
    return bool(values.min() >= lo - tol and values.max() <= hi + tol)


def figure_problems(fig, name: str = "figure") -> list[str]:
    """Everything wrong with ``fig`` as sentences; empty for a good figure."""
    renderer = _renderer(fig)
    box = fig.bbox
    problems = []
    for k, ax in enumerate(fig.axes):
        tag = f"{name} axes {k} ({ax.get_title() or ax.get_label()!r})"
        is_colorbar = ax.get_label() == "<colorbar>"
        for axis, what in ((ax.xaxis, "x"), (ax.yaxis, "y")):
            for side in _ticks_in_view(axis):
                boxes = [t.get_window_extent(renderer) for t in side]
                for a, b, ta, tb in zip(boxes, boxes[1:], side, side[1:]):
                    if a.padded(GAP_PX / 2).overlaps(b.padded(GAP_PX / 2)):
                        problems.append(f"{tag}: {what} tick labels {ta.get_text()!r} and "
                                        f"{tb.get_text()!r} overlap")
            drawn = ax.get_lines() or ax.collections or ax.images
            if drawn and not is_colorbar and _shows_ticks(axis) and not axis.label.get_text():
                problems.append(f"{tag}: no {what} label")
        x0, x1 = ax.get_xlim()
        y0, y1 = ax.get_ylim()
        for line in ax.get_lines():
            if line.get_transform() != ax.transData:
                continue  # axhline/axvline: in axes coordinates along one direction
            xd, yd = np.asarray(line.get_xdata(), float), np.asarray(line.get_ydata(), float)
            drawn_points = np.isfinite(xd) & np.isfinite(yd)  # a NaN coordinate is not drawn
            xd, yd = xd[drawn_points], yd[drawn_points]
            if xd.size > 1 and not (_inside(x0, x1, xd) and _inside(y0, y1, yd)):
                problems.append(f"{tag}: line {line.get_label()!r} leaves the limits "
                                f"x {x0:.3g}..{x1:.3g}, y {y0:.3g}..{y1:.3g}")
        texts = [ax.xaxis.label, ax.yaxis.label, ax.title, *ax.texts]
        for text in texts:
            if text.get_text() and text.get_visible():
                e = text.get_window_extent(renderer)
                if e.x0 < box.x0 - EDGE_PX or e.x1 > box.x1 + EDGE_PX or e.y0 < box.y0 - EDGE_PX \
                        or e.y1 > box.y1 + EDGE_PX:
                    problems.append(f"{tag}: text {text.get_text()[:40]!r} is clipped")
    suptitle = fig.get_suptitle()
    if suptitle:
        e = fig._suptitle.get_window_extent(renderer)
        if e.x0 < box.x0 - EDGE_PX or e.x1 > box.x1 + EDGE_PX:
            problems.append(f"{name}: suptitle is clipped")
    return problems
