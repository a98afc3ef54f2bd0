"""A design drawn: both parts' outlines, mated and at a start pose, as a PNG/SVG picture
(matplotlib) and as the geometry the CAD drawing (:mod:`xface_core.viz.facecad`) writes.

:func:`face_drawing` is the one place the drawn geometry comes from, for the picture and the
DXF alike: the polygons are :class:`~xface_core.geometry.FaceDesign`'s own
(``base_outline_world``, ``moving_outline_world``, what the rerun recording draws), placed as
the simulator places them:

mated
    The base at its body frame (pivot at the origin, ``phi_b = 0``), the moving part seated
    at ``x0 = 0``: pivot at ``(0, L)``, ``phi_m = 0``.
start
    The pose :func:`~xface_core.predict` starts from: the base at ``phi_b = 0``, the moving
    pivot at ``(x0, y_start)`` turned by ``theta0``, where ``y_start`` is predict's default
    (just clear of the base at this angle, :func:`~xface_core.runner.start_height`).

Lengths are in the design's length unit (the body frames' units of D times ``design.width``),
angles in radians. matplotlib is imported only by the picture functions, so that the CAD
drawing needs the ``cad`` extra alone.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Literal, NamedTuple

import numpy as np
import numpy.typing as npt

from xface_core.frames import check_facing
from xface_core.geometry import FaceDesign
from xface_core.runner import check_pose, start_height
from xface_core.viz.palette import BASE_LAYERS, BLACK, MOVING_LAYERS, hex_color

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from xface_core.viz.figures import PictureFormat

__all__ = [
    "MAX_LABEL_CHARS",
    "FaceDrawing",
    "PartOutline",
    "PartsAtPose",
    "StartPose",
    "draw_face",
    "face_drawing",
    "save_face_picture",
]

FloatArray = npt.NDArray[np.float64]
Part = Literal["base", "moving"]


class PartOutline(NamedTuple):
    """One layer of one part: its closed polygon, (v, 2) vertices in the design's length
    unit, the first vertex not repeated."""

    part: Part
    layer: int
    vertices: FloatArray


class PartsAtPose(NamedTuple):
    """Both parts in one pose: every layer's outline (base layers first) and both pivots
    (design's length unit)."""

    outlines: tuple[PartOutline, ...]
    base_pivot: tuple[float, float]
    moving_pivot: tuple[float, float]


class StartPose(NamedTuple):
    """A start pose as :func:`~xface_core.predict` takes it: ``x0`` and ``y_start`` in the
    design's length unit, ``theta0`` in radians."""

    x0: float
    theta0: float
    y_start: float


class FaceDrawing(NamedTuple):
    """What a drawing of a design shows.

    Attributes
    ----------
    design : FaceDesign
    title : str
        The design's name (a face file's ``name:``) or its built-in label, plain text.
    unit : str
        The name of the length unit of every coordinate ("D" when the width is 1 and no unit
        is named).
    mated : PartsAtPose
        Both parts seated at ``x0 = 0``.
    start : PartsAtPose or None
        Both parts at the start pose, when one is given.
    start_pose : StartPose or None
    """

    design: FaceDesign
    title: str
    unit: str
    mated: PartsAtPose
    start: PartsAtPose | None
    start_pose: StartPose | None


#: Longest title and unit name drawn (characters): a face file's free-text name may be long
#: (up to the file's 1 MiB), and a picture as wide as that would not be drawn at all.
MAX_LABEL_CHARS = 120


def _one_line_label(text: str | None) -> str | None:
    """``text`` on one line (every run of white space, line breaks included, one space: a DXF
    value cannot hold a line break), at most :data:`MAX_LABEL_CHARS` characters (cut with an
    ellipsis); None for None or blank text."""
    if text is None:
        return None
    line = " ".join(text.split())
    if len(line) > MAX_LABEL_CHARS:
        line = line[: MAX_LABEL_CHARS - 1] + "\u2026"
    return line or None


def _design_label(design: FaceDesign) -> str:
    """A built-in design's plain-text name: "X-Face, H/D = 0.25, r_p = 1 D"."""
    if design.kind == "custom":
        return f"custom face, L = {design.mated_distance:g} D"
    return f"{design.kind}-Face, H/D = {design.h_over_d:g}, r_p = {design.r_p:g} D"


def _parts_at(design: FaceDesign, x0_d: float, y_m_d: float, phi_m: float) -> PartsAtPose:
    """Both parts with the base at phi_b = 0 and the moving pivot at (x0_d, y_m_d) (units of
    D) turned by phi_m, scaled to the design's length unit."""
    w = design.width
    base = [
        PartOutline("base", k, design.base_outline_world(k, 0.0) * w)
        for k in range(design.n_layers)
    ]
    moving = [
        PartOutline("moving", k, design.moving_outline_world(k, x0_d, y_m_d, phi_m) * w)
        for k in range(design.n_layers)
    ]
    return PartsAtPose(tuple(base + moving), (0.0, 0.0), (x0_d * w, y_m_d * w))


def face_drawing(
    design: FaceDesign,
    *,
    pose: tuple[float, float] | None = None,
    name: str | None = None,
    unit: str | None = None,
) -> FaceDrawing:
    """The geometry of a drawing of ``design``: both parts mated and, with ``pose = (x0,
    theta0)`` (design's length unit, rad; predict's conventions), at predict's start pose.

    ``name`` titles the drawing (default: the design's own name, a face file's ``name:``
    (:attr:`~xface_core.geometry.FaceDesign.name`), else its built-in label);
    ``unit`` names the length unit (default: "D" when ``design.width`` is 1, else
    "length unit, D = <width>"). Both are drawn on one line, cut to
    :data:`MAX_LABEL_CHARS` characters.

    Raises
    ------
    InputError
        The pose is one predict refuses (non-finite, absurd, the faces not facing).

    Examples
    --------
    >>> from xface_core import x_face
    >>> drawing = face_drawing(x_face(0.25, 1.0), pose=(0.1, 0.2))
    >>> drawing.unit, [(o.part, o.layer) for o in drawing.mated.outlines]
    ('D', [('base', 0), ('base', 1), ('moving', 0), ('moving', 1)])
    >>> drawing.start.moving_pivot[0]
    0.1
    """
    w = design.width
    start = start_pose = None
    if pose is not None:
        x0, theta0 = float(pose[0]), float(pose[1])
        check_pose(design, x0, theta0, None)
        check_facing(theta0)
        y_start_d = start_height(design, theta0)  # predict's default start, units of D
        start_pose = StartPose(x0, theta0, y_start_d * w)
        start = _parts_at(design, x0 / w, y_start_d, theta0)
    title, unit = _one_line_label(name if name is not None else design.name), _one_line_label(unit)
    return FaceDrawing(
        design=design,
        title=_design_label(design) if title is None else title,
        unit=(f"length unit, D = {w:g}" if w != 1.0 else "D") if unit is None else unit,
        mated=_parts_at(design, 0.0, design.mated_distance, 0.0),
        start=start,
        start_pose=start_pose,
    )


# --- the picture (matplotlib) -----------------------------------------------------------------

#: Colours per layer (layer k takes k % 2), those of the rerun recording: blue and sky blue
#: for the base, vermillion and orange for the moving part (Okabe-Ito, colour-blind safe).
_PART_COLORS: dict[Part, tuple[str, str]] = {
    "base": (hex_color(BASE_LAYERS[0]), hex_color(BASE_LAYERS[1])),
    "moving": (hex_color(MOVING_LAYERS[0]), hex_color(MOVING_LAYERS[1])),
}
_PIVOT_COLOR = hex_color(BLACK)
#: Pixels per length unit are chosen so that the larger side of the largest panel has this
#: many pixels.
_PANEL_PX = 420
#: Pixels above and beside the design's title.
_TITLE_MARGIN_PX = 10


def _extent(parts: PartsAtPose) -> tuple[float, float, float, float]:
    """(x_min, x_max, y_min, y_max) of everything a panel draws, with a border of 5 %."""
    points = np.vstack(
        [o.vertices for o in parts.outlines] + [np.array([parts.base_pivot, parts.moving_pivot])]
    )
    lo, hi = points.min(axis=0), points.max(axis=0)
    pad = 0.05 * float(max(hi - lo))
    return (lo[0] - pad, hi[0] + pad, lo[1] - pad, hi[1] + pad)


def _draw_panel(ax: Axes, parts: PartsAtPose, heading: str, unit: str, legend: bool) -> None:
    """One pose: every layer's outline, both pivots, the axes in the drawing's unit."""
    for outline in parts.outlines:
        ring = np.vstack((outline.vertices, outline.vertices[:1]))
        ax.plot(
            ring[:, 0],
            ring[:, 1],
            color=_PART_COLORS[outline.part][outline.layer % 2],
            linewidth=1.5,
            label=f"{outline.part} layer {outline.layer}" if legend else None,
        )
    pivots = np.array([parts.base_pivot, parts.moving_pivot])
    ax.plot(
        pivots[:, 0],
        pivots[:, 1],
        linestyle="none",
        marker="+",
        markersize=10,
        markeredgewidth=1.5,
        color=_PIVOT_COLOR,
        label="pivots" if legend else None,
    )
    x_min, x_max, y_min, y_max = _extent(parts)
    ax.set_xlim(x_min, x_max)
    ax.set_ylim(y_min, y_max)
    ax.set_aspect("equal")
    ax.set_xlabel(f"x ({unit})", parse_math=False)
    ax.set_ylabel(f"y ({unit})", parse_math=False)
    ax.set_title(heading, fontsize=10)
    ax.grid(True, linewidth=0.5, color="#dddddd")


def draw_face(drawing: FaceDrawing) -> Figure:
    """The drawing as a figure: a "mated" panel and, with a start pose, a "start" panel
    beside it at the same scale; the title names the design, a legend the layers.

    Examples
    --------
    >>> from xface_core import v_face
    >>> fig = draw_face(face_drawing(v_face(0.5, 1.0), pose=(0.2, -0.1)))
    >>> [ax.get_title() for ax in fig.axes]
    ['mated', 'start: x0 = 0.2, theta0 = -0.1 rad, y = 3.05']
    """
    from xface_core.viz.figures import fit_axes, new_figure

    panels = [(drawing.mated, "mated")]
    if drawing.start is not None and drawing.start_pose is not None:
        p = drawing.start_pose
        heading = f"start: x0 = {p.x0:.3g}, theta0 = {p.theta0:.3g} rad, y = {p.y_start:.3g}"
        panels.append((drawing.start, heading))
    extents = [_extent(parts) for parts, _ in panels]
    largest = max(max(e[1] - e[0], e[3] - e[2]) for e in extents)
    scale = _PANEL_PX / largest  # pixels per length unit, shared by the panels
    fig = new_figure()
    sized = []
    for i, ((parts, heading), e) in enumerate(zip(panels, extents, strict=True)):
        ax = fig.add_subplot()
        _draw_panel(ax, parts, heading, drawing.unit, legend=i == len(panels) - 1)
        size = (max(1, round((e[1] - e[0]) * scale)), max(1, round((e[3] - e[2]) * scale)))
        sized.append((ax, *size))
    last = sized[-1][0]
    last.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=9, frameon=False)
    fit_axes(fig, sized, gap=20)
    _place_title(fig, drawing.title)
    return fig


def _place_title(fig: Figure, title: str) -> None:
    """The design's title centred above the panels, as plain text (a face file's name may
    hold ``$`` or ``\\``, which mathtext would try to parse): the figure grows at the top by
    the title's height, and in width when the title is wider; the panels keep their size in
    pixels (:func:`~xface_core.viz.figures.fit_axes` lays out the axes' own text only)."""
    from xface_core.viz.figures import DPI

    text = fig.suptitle(title, fontsize=11, va="top", parse_math=False)
    box = text.get_window_extent(fig.canvas.get_renderer())  # type: ignore[attr-defined]
    old_w, old_h = (round(v * DPI) for v in fig.get_size_inches())
    new_w = max(old_w, math.ceil(box.width) + 2 * _TITLE_MARGIN_PX)
    new_h = old_h + math.ceil(box.height) + _TITLE_MARGIN_PX
    shift = (new_w - old_w) // 2  # whole pixels: the panels stay on the pixel grid
    for ax in fig.axes:
        b = ax.get_position()
        ax.set_position(
            (
                (b.x0 * old_w + shift) / new_w,
                b.y0 * old_h / new_h,
                b.width * old_w / new_w,
                b.height * old_h / new_h,
            )
        )
    fig.set_size_inches(new_w / DPI, new_h / DPI)
    text.set_y(1.0 - _TITLE_MARGIN_PX / new_h)


def save_face_picture(
    drawing: FaceDrawing, path: str | Path, *, fmt: PictureFormat | None = None
) -> Path:
    """Write :func:`draw_face`'s figure as PNG or SVG (``fmt``, default from the suffix), the
    same bytes for the same drawing (:func:`xface_core.viz.figures.save`).

    Raises
    ------
    XfaceValueError
        The suffix is neither .png nor .svg and no ``fmt`` is given.
    OSError
        The file cannot be written.
    """
    from xface_core.viz.figures import save

    return save(draw_face(drawing), path, fmt)
