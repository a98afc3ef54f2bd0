"""Acceptance maps as figures with real axes (matplotlib): PNG or SVG, outcome colours with
a legend of the counts, the guaranteed region(s) with their extents, the aligned pose and
the reach limit marked, the design and M in the title.

theta0 runs along the horizontal axis in degrees, x0 up the vertical axis (in D, or the
design's length unit when D is not 1). The colours, the checks of a map and its regions as
grid indices are :mod:`xface_core.viz.mapgrid`'s (re-exported here, where they used to be).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import numpy.typing as npt
from matplotlib.artist import Artist
from matplotlib.axes import Axes
from matplotlib.colors import BoundaryNorm, ListedColormap
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch, Rectangle
from matplotlib.ticker import MaxNLocator

from xface_core.codes import Outcome
from xface_core.errors import XfaceValueError
from xface_core.geometry import FaceDesign
from xface_core.viz.figures import (
    PictureFormat,
    PixelBox,
    fit_axes,
    new_figure,
    picture_format,
    pt,
    save,
)
from xface_core.viz.mapgrid import (
    _COLORS,
    GUARANTEED_OUTLINE,
    RGB,
    AcceptanceMapLike,
    MapPicture,
    check_scale,
    checked_grid,
    guaranteed_cells,
    map_to_rgb,
    outcome_colors,
    region_cells,
)

__all__ = [
    "GUARANTEED_OUTLINE",
    "AcceptanceMapLike",
    "MapPicture",
    "cell_edges",
    "cell_pixels",
    "checked_grid",
    "design_title",
    "draw_map",
    "guaranteed_cells",
    "map_figure",
    "map_to_rgb",
    "outcome_colors",
    "save_map_picture",
    "save_map_png",
]


# --- the picture (matplotlib) -----------------------------------------------------------------

#: Colour of the reach limit |x0| = L and of the centred region's outline.
_REACH_COLOR = (0.25, 0.25, 0.25)


def rgb01(color: RGB) -> tuple[float, float, float]:
    """An 8-bit RGB colour as matplotlib's 0..1 floats."""
    return (color[0] / 255.0, color[1] / 255.0, color[2] / 255.0)


def cell_edges(values: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """Cell edges around grid nodes: half way between neighbours, half a step past the ends
    (a one-node axis gets a cell of width 1)."""
    if values.size == 1:
        return np.array([values[0] - 0.5, values[0] + 0.5])
    mid = 0.5 * (values[1:] + values[:-1])
    return np.concatenate(
        ([values[0] - (mid[0] - values[0])], mid, [values[-1] + (values[-1] - mid[-1])])
    )


def _length_unit(design: FaceDesign) -> str:
    """The unit x0 is drawn in: D itself, or the design's length unit when D is not 1 (a face
    file names no unit: its width is D in the designer's own)."""
    return "D" if design.width == 1.0 else f"your unit, D = {design.width:g}"


def _mathtext_safe(text: str) -> str:
    """``text`` shown as written in a matplotlib title: its ``$`` escaped (a file's name is
    free text; two dollars would start mathtext, and an odd one makes drawing fail)."""
    return text.replace("$", r"\$")


def design_title(design: FaceDesign) -> str:
    """A design as a picture's title names it: "X-Face, H/D = 0.25, r_p = 1 D" (mathtext);
    a custom face by its name (a face file's ``name:``)."""
    if design.kind == "custom":
        return f"{_mathtext_safe(design.display_name)}, L = {design.mated_distance:g} D"
    return f"{design.kind}-Face, H/D = {design.h_over_d:g}, $r_p$ = {design.r_p:g} D"


def _counts(amap: AcceptanceMapLike, outcomes: npt.NDArray[np.int64]) -> dict[Outcome, int]:
    """Cells per outcome; ``amap.M`` must be the SEATED count."""
    counts = {o: int(np.count_nonzero(outcomes == int(o))) for o in Outcome}
    if int(amap.M) != counts[Outcome.SEATED]:
        raise XfaceValueError(
            f"map.M = {amap.M} but the grid has {counts[Outcome.SEATED]} SEATED cells"
        )
    return counts


def _extent_label(
    name: str,
    rect: tuple[int, int, int, int],
    x0: npt.NDArray[np.float64],
    theta0: npt.NDArray[np.float64],
    unit: str,
) -> str:
    """The region's name, size in cells and its node extents (x0 in ``unit``, theta0 in
    degrees): the same numbers as ``xface map``'s text and JSON."""
    r0, r1, c0, c1 = rect
    t_lo, t_hi = np.degrees(theta0[c0]), np.degrees(theta0[c1 - 1])
    unit = "D" if unit == "D" else f"({unit})"
    return (
        f"{name}, {r1 - r0} x {c1 - c0} cells:\n"
        f"$x_0$ in [{x0[r0]:.3g}, {x0[r1 - 1]:.3g}] {unit}\n"
        rf"$\theta_0$ in [{t_lo:.3g}, {t_hi:.3g}] deg"
    )


def _draw_region(
    ax: Axes,
    rect: tuple[int, int, int, int],
    x_edges: npt.NDArray[np.float64],
    t_edges: npt.NDArray[np.float64],
    *,
    dashed: bool,
) -> Rectangle:
    r0, r1, c0, c1 = rect
    box = Rectangle(
        (t_edges[c0], x_edges[r0]),
        t_edges[c1] - t_edges[c0],
        x_edges[r1] - x_edges[r0],
        fill=False,
        edgecolor=rgb01(GUARANTEED_OUTLINE) if not dashed else "white",
        linewidth=pt(3 if not dashed else 2),
        linestyle=(0, (3, 2)) if dashed else "-",
        zorder=3,
    )
    ax.add_patch(box)
    return box


def _axis_ticks(ax: Axes, t_edges: npt.NDArray[np.float64]) -> None:
    """Degrees in steps of 15, 30 or 60 on the usual half turn (as many as the axis length
    has room for), matplotlib's own steps on small ranges; x0 keeps matplotlib's steps."""
    if float(t_edges[-1] - t_edges[0]) >= 60.0:
        ax.xaxis.set_major_locator(MaxNLocator(nbins="auto", steps=[1.5, 3, 6, 10]))
    ax.tick_params(labelsize=9)


def draw_map(ax: Axes, amap: AcceptanceMapLike, *, title: str | None = None) -> list[Artist]:
    """Draw the map on ``ax``: cells in their outcome colours, the guaranteed region(s), the
    aligned pose, the reach limit |x0| = L where it lies on the plot, axis labels and title.

    theta0 (degrees) runs along the horizontal axis, x0 (D, or the design's length unit)
    up. Returns the legend handles (each with its label set), for the caller to place.

    Raises
    ------
    XfaceValueError
        The map is malformed (see :func:`guaranteed_cells`) or ``amap.M`` disagrees with the
        number of SEATED cells.
    """
    x0, theta0, outcomes = checked_grid(amap)
    counts = _counts(amap, outcomes)
    rect = guaranteed_cells(amap)
    centred = region_cells(outcomes, getattr(amap, "centred", None), "centred")
    design = amap.design
    unit = _length_unit(design)
    t_deg = np.degrees(theta0)
    x_edges, t_edges = cell_edges(x0), cell_edges(t_deg)

    cmap = ListedColormap([rgb01(_COLORS[o]) for o in sorted(Outcome, key=int)])
    norm = BoundaryNorm(np.arange(len(Outcome) + 1) - 0.5, len(Outcome))
    # rasterized: a 1001 x 1001 map stays one image in an SVG instead of a million paths.
    ax.pcolormesh(t_edges, x_edges, outcomes, cmap=cmap, norm=norm, antialiased=False)
    ax.collections[-1].set_rasterized(True)
    ax.set_xlim(t_edges[0], t_edges[-1])
    ax.set_ylim(x_edges[0], x_edges[-1])
    ax.set_xlabel(r"initial angle $\theta_0$ (deg)", fontsize=10)
    ax.set_ylabel(f"lateral offset $x_0$ ({unit})", fontsize=10)
    _axis_ticks(ax, t_edges)
    heading = title if title is not None else design_title(design)
    ax.set_title(f"{heading}\nM = {amap.M} of {outcomes.size} seated", fontsize=10)

    handles: list[Artist] = [
        Patch(
            facecolor=rgb01(_COLORS[o]),
            edgecolor="0.35",
            label=f"{o.name.lower().replace('_', ' ')} ({counts[o]})",
        )
        for o in Outcome
        if counts[o]
    ]
    if rect is None:
        handles.append(Patch(facecolor="none", edgecolor="none", label="guaranteed: none"))
    else:
        box = _draw_region(ax, rect, x_edges, t_edges, dashed=False)
        name = "guaranteed = centred" if centred == rect else "guaranteed"
        box.set_label(_extent_label(name, rect, x0, theta0, unit))
        handles.append(box)
    if centred is not None and centred != rect:
        box = _draw_region(ax, centred, x_edges, t_edges, dashed=True)
        box.set_label(_extent_label("centred on the aligned pose", centred, x0, theta0, unit))
        handles.append(
            Patch(
                facecolor=rgb01(_COLORS[Outcome.SEATED]),
                edgecolor="white",
                linestyle=(0, (3, 2)),
                linewidth=pt(2),
                label=box.get_label(),
            )
        )
    if x_edges[0] <= 0.0 <= x_edges[-1] and t_edges[0] <= 0.0 <= t_edges[-1]:
        (aligned,) = ax.plot(
            [0.0], [0.0], marker="P", markersize=pt(11), color="black",
            markeredgecolor="white", markeredgewidth=pt(1.5), linestyle="none", zorder=4,
            label=r"aligned pose ($x_0$ = 0, $\theta_0$ = 0)",
        )  # fmt: skip
        handles.append(aligned)
    reach = design.mated_distance * design.width
    shown = [y for y in (-reach, reach) if x_edges[0] < y < x_edges[-1]]
    for y in shown:
        ax.axhline(y, color=_REACH_COLOR, linewidth=pt(1.5), linestyle="--", zorder=2)
    if shown:
        length = f"{reach:.3g} D" if unit == "D" else f"{reach:.3g}"
        handles.append(
            Line2D([], [], color=_REACH_COLOR, linestyle="--", linewidth=pt(1.5),
                   label=f"reach limit $|x_0|$ = L = {length}")
        )  # fmt: skip
    return handles


def cell_pixels(shape: tuple[int, ...], *, most: int = 8, room: int = 660) -> int:
    """Pixels per cell side for a grid of ``shape``: ``most``, or fewer so the cells stay
    within about ``room`` pixels, at least 1 (a 41 x 41 map gets 8, 161 x 161 gets 4,
    1001 x 1001 gets 1; a picture of 8 pixels per cell of a 1001 grid would be 64 megapixels).

    Examples
    --------
    >>> cell_pixels((41, 41)), cell_pixels((161, 161)), cell_pixels((1001, 1001))
    (8, 4, 1)
    """
    return max(1, min(most, room // max(shape)))


def map_figure(
    amap: AcceptanceMapLike, *, scale: int | None = None, title: str | None = None
) -> tuple[Figure, PixelBox]:
    """The map as a figure (see :func:`draw_map`) with its legend on the right; each cell
    ``scale`` x ``scale`` pixels (default: :func:`cell_pixels`). Returns the figure and the
    cells' pixel box in it."""
    _, _, outcomes = checked_grid(amap)
    n, m = outcomes.shape
    scale = cell_pixels(outcomes.shape) if scale is None else check_scale(scale)
    fig = new_figure()
    ax = fig.add_axes((0.1, 0.1, 0.5, 0.5))
    handles = draw_map(ax, amap, title=title)
    ax.legend(
        handles=handles,
        loc="upper left",
        bbox_to_anchor=(1.03, 1.0),
        borderaxespad=0.0,
        frameon=False,
        fontsize=9,
        labelspacing=0.6,
    )
    (box,) = fit_axes(fig, [(ax, m * scale, n * scale)])
    return fig, box


def save_map_picture(
    amap: AcceptanceMapLike,
    path: str | Path,
    *,
    scale: int | None = None,
    title: str | None = None,
    fmt: PictureFormat | None = None,
) -> MapPicture:
    """Write the map as a PNG or SVG picture (``fmt``, default: from the path's suffix).

    Layout: theta0 (degrees) on the horizontal axis, x0 (D) on the vertical axis (x0 grows
    upwards), the guaranteed-acceptance rectangle outlined in black (the largest one centred
    on the aligned pose dashed white when it differs), the aligned pose marked with a cross,
    the reach limit |x0| = L dashed; a legend on the right with the count of every outcome
    present and the regions' extents; the design and M in the title.

    Parameters
    ----------
    amap : AcceptanceMapLike
        The map to draw.
    path : str or Path
        Where to write (the parent folder must exist).
    scale : int, optional
        Pixels per cell side, 1..64; default :func:`cell_pixels` (8 up to 82 nodes per
        axis, fewer on larger grids).
    title : str, optional
        The first title line; ``M = ... of ... seated`` always follows. Default: the design
        ("X-Face, H/D = 0.25, r_p = 1 D").
    fmt : {"png", "svg"}, optional
        The file format; default from the suffix of ``path``.

    Returns
    -------
    MapPicture
        The path, the picture's size and the pixel box of the cells.

    Raises
    ------
    XfaceValueError
        The map is malformed (see :func:`guaranteed_cells`), ``amap.M`` disagrees with the
        number of SEATED cells, ``scale`` is out of range, or the suffix is neither .png nor
        .svg (without ``fmt``).

    Examples
    --------
    >>> import tempfile
    >>> from types import SimpleNamespace
    >>> from xface_core import v_face
    >>> grid = np.full((5, 7), int(Outcome.SEATED))
    >>> amap = SimpleNamespace(
    ...     x0=np.linspace(-1, 1, 5),
    ...     theta0=np.linspace(-1.5, 1.5, 7),
    ...     outcomes=grid,
    ...     M=35,
    ...     design=v_face(1.0, 1.0),
    ...     guaranteed=(slice(0, 5), slice(0, 7)),
    ... )
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     picture = save_map_picture(amap, Path(tmp) / "map.svg", scale=4)
    >>> picture.cells[2] - picture.cells[0], picture.cells[3] - picture.cells[1]
    (28, 20)
    """
    kind = picture_format(path) if fmt is None else fmt
    fig, box = map_figure(amap, scale=scale, title=title)
    out = save(fig, path, kind)
    size = fig.canvas.get_width_height()
    return MapPicture(path=out, size=(int(size[0]), int(size[1])), cells=tuple(box))  # type: ignore[arg-type]


def save_map_png(
    amap: AcceptanceMapLike,
    path: str | Path,
    *,
    scale: int | None = None,
    title: str | None = None,
) -> MapPicture:
    """:func:`save_map_picture` as PNG, whatever the suffix of ``path``."""
    return save_map_picture(amap, path, scale=scale, title=title, fmt="png")
