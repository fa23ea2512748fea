"""Figure layout shared by every figure granflow writes (:mod:`granflow.plotting`,
:mod:`granflow.case_figures`): tick labels that do not overlap ("0.00.010.0203" in the narrow
panels of a tall box), and saving. matplotlib is imported lazily (Agg backend)."""
from __future__ import annotations

from pathlib import Path


def pyplot():
    """``matplotlib.pyplot`` on the Agg backend (imported on first use: the CLI stays light)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


MIN_TICK_INTERVALS = 1
"""Fewest intervals between major ticks :func:`thin_ticks` asks of an axis."""
TICK_STEPS = (1, 2, 2.5, 5, 10)
"""Tick spacings (times a power of ten) :func:`thin_ticks` may choose."""
TICK_GAP_PX = 2.0
"""Least gap [px] between two neighbouring tick labels; closer labels count as overlapping."""
VERTICAL_DEG = 90
"""Rotation of x tick labels when even two of them do not fit side by side."""
TICK_VIEW_TOL = 1e-9
"""Ticks within this fraction of the axis range outside the view interval count as inside."""


def drawn_tick_labels(axis) -> list[list]:
    """The tick labels ``axis`` draws, per side (bottom/left, then top/right): visible, non-empty
    and within the view interval (matplotlib keeps labels for ticks outside it, not drawn)."""
    locs = axis.get_majorticklocs()
    lo, hi = sorted(axis.get_view_interval())
    tol = TICK_VIEW_TOL * (hi - lo)
    inside = [tick for tick, loc in zip(axis.get_major_ticks(len(locs)), locs) if lo - tol <= loc <= hi + tol]
    return [[lab for lab in (getattr(t, side) for t in inside) if lab.get_visible() and lab.get_text()]
            for side in ("label1", "label2")]


def overlapping_tick_labels(axis, renderer) -> list[tuple[str, str]]:
    """Pairs of neighbouring drawn tick labels of ``axis`` (a matplotlib XAxis/YAxis of a drawn
    figure) closer than :data:`TICK_GAP_PX`: ``[("0.00", "0.01"), ...]``, empty if they fit."""
    pairs = []
    for labels in drawn_tick_labels(axis):
        boxes = [t.get_window_extent(renderer).padded(TICK_GAP_PX / 2) for t in labels]
        pairs += [(a.get_text(), b.get_text()) for a, b, ba, bb in
                  zip(labels, labels[1:], boxes, boxes[1:]) if ba.overlaps(bb)]
    return pairs


def thin_ticks(fig) -> None:
    """Fewer ticks on every linear axis of ``fig`` whose tick labels overlap (the narrow panels of a
    tall box printed "0.00.010.0203"), and vertical x tick labels where even two do not fit; axes
    with fixed tick labels (categories) are left alone."""
    from matplotlib.ticker import FixedFormatter, MaxNLocator

    fig.canvas.draw()
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            if axis.get_scale() != "linear" or isinstance(axis.get_major_formatter(), FixedFormatter):
                continue
            intervals = max(len(side) for side in drawn_tick_labels(axis)) - 1
            while intervals > MIN_TICK_INTERVALS and overlapping_tick_labels(axis, fig.canvas.get_renderer()):
                intervals -= 1
                axis.set_major_locator(MaxNLocator(nbins=intervals, steps=TICK_STEPS))
                fig.canvas.draw()
            if axis is ax.xaxis and overlapping_tick_labels(axis, fig.canvas.get_renderer()):
                ax.tick_params(axis="x", labelrotation=VERTICAL_DEG)  # a panel narrower than 2 labels
                fig.canvas.draw()


def save_figure(fig, path: str | Path, dpi: int) -> Path:
    """Write ``fig`` to ``path`` (ticks thinned where their labels would overlap) and close it."""
    thin_ticks(fig)
    fig.savefig(path, dpi=dpi)
    import matplotlib.pyplot as plt

    plt.close(fig)
    return Path(path)
