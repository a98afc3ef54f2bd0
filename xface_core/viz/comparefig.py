"""Two acceptance maps side by side and their difference map, as one PNG or SVG figure.

Left: map A, middle: map B (each as :func:`~xface_core.viz.mapimage.draw_map` draws it),
right: where each seats (both, only A, only B, neither) with the counts in its legend. Two
designs of different widths are drawn in units of D, both on one x0 / D axis
(:func:`~xface_core.viz.mapdiff.map_difference` compares them there); the panels' titles name
each design's width.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.artist import Artist
from matplotlib.axes import Axes
from matplotlib.colors import BoundaryNorm, ListedColormap
from matplotlib.figure import Figure
from matplotlib.patches import Patch
from matplotlib.transforms import offset_copy

from xface_core.viz import palette
from xface_core.viz.figures import PictureFormat, fit_axes, new_figure, picture_format, save
from xface_core.viz.mapdiff import MapDifference, SeatedIn, in_units_of_d, map_difference
from xface_core.viz.mapgrid import AcceptanceMapLike, check_scale, checked_grid
from xface_core.viz.mapimage import cell_edges, cell_pixels, draw_map, rgb01

__all__ = ["DIFFERENCE_COLORS", "comparison_figure", "save_comparison"]

#: How far below its panel's bottom edge a legend starts, in points: below the tick labels
#: and the axis label (10-point text: about 40 points together) whatever the panel's height.
#: A fraction of the panel's height, as before, put the legends over the axis labels on
#: grids of 21 nodes and fewer (a 126-pixel panel: 16 % is 20 pixels).
LEGEND_DROP_POINTS = 46.0

#: Smallest side of a panel, in pixels, when the scale is chosen here: the y-axis label is
#: about this long, and the tick labels of a 66-pixel panel (11 nodes at 6 pixels) ran into
#: each other and the label into the title.
MIN_PANEL_PIXELS = 200

#: Colour per :class:`SeatedIn` value: Okabe-Ito blue / orange for "only A" / "only B" (the
#: pair told apart with every common colour-vision deficiency), the maps' SEATED green for
#: both, a pale grey for neither.
DIFFERENCE_COLORS: dict[SeatedIn, tuple[int, int, int]] = {
    SeatedIn.NEITHER: (235, 235, 235),
    SeatedIn.ONLY_A: palette.BLUE,
    SeatedIn.ONLY_B: palette.ORANGE,
    SeatedIn.BOTH: palette.BLUISH_GREEN,
}

_NAMES = {
    SeatedIn.BOTH: "seated in both",
    SeatedIn.ONLY_A: "only in A",
    SeatedIn.ONLY_B: "only in B",
    SeatedIn.NEITHER: "in neither",
}


def save_comparison(
    a: AcceptanceMapLike,
    b: AcceptanceMapLike,
    path: str | Path,
    *,
    labels: tuple[str, str] | None = None,
    scale: int | None = None,
    fmt: PictureFormat | None = None,
) -> MapDifference:
    """Write A, B and their difference map side by side to ``path`` (PNG or SVG, ``fmt`` or
    the suffix); ``labels`` are the panels' first title lines (default: the designs);
    ``scale`` pixels per cell side (default: 6 on grids from 34 to 83 nodes, fewer above, more
    below: a panel is at least :data:`MIN_PANEL_PIXELS` wide).

    Returns
    -------
    MapDifference
        The counts the difference panel shows.

    Raises
    ------
    XfaceValueError
        The maps are malformed or do not share their grid (see
        :func:`~xface_core.viz.mapdiff.map_difference`), ``scale`` is not 1..64, or the
        suffix is neither .png nor .svg (without ``fmt``).
    """
    kind = picture_format(path) if fmt is None else fmt
    fig, diff = comparison_figure(a, b, labels=labels, scale=scale)
    save(fig, path, kind)
    return diff


def _legend_below(fig: Figure, ax: Axes, handles: list[Artist]) -> None:
    """The panel's legend below its axis label, :data:`LEGEND_DROP_POINTS` under its edge."""
    below = offset_copy(ax.transAxes, fig=fig, y=-LEGEND_DROP_POINTS, units="points")
    ax.legend(
        handles=handles,
        loc="upper center",
        bbox_to_anchor=(0.5, 0.0),
        bbox_transform=below,
        borderaxespad=0.0,
        frameon=False,
        fontsize=8,
        ncols=1,
    )


def comparison_figure(
    a: AcceptanceMapLike,
    b: AcceptanceMapLike,
    *,
    labels: tuple[str, str] | None = None,
    scale: int | None = None,
) -> tuple[Figure, MapDifference]:
    """The figure :func:`save_comparison` writes, laid out and not saved (for a caller, or a
    test, that reads its layout); the same arguments and errors."""
    diff = map_difference(a, b)
    if a.design.width != b.design.width:  # one x0 axis for both: units of D
        a, b = in_units_of_d(a), in_units_of_d(b)
    x0, theta0, outcomes = checked_grid(a)
    n, m = outcomes.shape
    # Three panels: smaller cells than one map's (6 pixels on the usual 41 x 41 grid).
    if scale is None:
        # Small grids get larger cells: a panel narrower than its own labels crowds them.
        fitted = cell_pixels(outcomes.shape, most=6, room=500)
        scale = max(fitted, math.ceil(MIN_PANEL_PIXELS / max(n, m)))
    else:
        scale = check_scale(scale)
    fig = new_figure()
    first = fig.add_axes((0.1, 0.1, 0.2, 0.5))
    # Shared axes: the difference panel gets the maps' limits and ticks.
    panels = [first] + [
        fig.add_axes((0.4 + 0.3 * k, 0.1, 0.2, 0.5), sharex=first, sharey=first) for k in range(2)
    ]
    for ax, amap, tag, label in zip(panels, (a, b), "AB", labels or (None, None), strict=False):
        handles = draw_map(ax, amap, title=f"{tag}: {label}" if label else None)
        if not label:
            ax.set_title(f"{tag}: {ax.get_title()}", fontsize=10)
        _legend_below(fig, ax, handles)
    ax = panels[2]
    colors = [rgb01(DIFFERENCE_COLORS[w]) for w in SeatedIn]
    ax.pcolormesh(
        cell_edges(np.degrees(theta0)),
        cell_edges(x0),
        diff.seated_in,
        cmap=ListedColormap(colors),
        norm=BoundaryNorm(np.arange(len(SeatedIn) + 1) - 0.5, len(SeatedIn)),
        antialiased=False,
        rasterized=True,
    )
    ax.set_xlabel(r"initial angle $\theta_0$ (deg)", fontsize=10)
    ax.set_title(f"difference: M(A) = {diff.M_a}, M(B) = {diff.M_b}\n"
                 f"same outcome in {diff.same_outcome} of {n * m} cells", fontsize=10)  # fmt: skip
    _legend_below(
        fig,
        ax,
        [
            Patch(facecolor=colors[w], edgecolor="0.35", label=f"{_NAMES[w]} ({diff.count(w)})")
            for w in (SeatedIn.BOTH, SeatedIn.ONLY_A, SeatedIn.ONLY_B, SeatedIn.NEITHER)
        ],
    )
    fit_axes(fig, [(p, m * scale, n * scale) for p in panels], gap=30)
    return fig, diff
