"""What every matplotlib picture of xface shares: a figure off pyplot, a layout in whole
pixels around axes of a chosen size, and byte-for-byte reproducible PNG and SVG files.

No pyplot: a :class:`~matplotlib.figure.Figure` with its own Agg canvas keeps no global
state, so pictures drawn from several threads or inside the ROS node do not meet.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Literal, NamedTuple

import matplotlib as mpl
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from xface_core.errors import XfaceValueError

__all__ = [
    "DPI",
    "PictureFormat",
    "PixelBox",
    "fit_axes",
    "new_figure",
    "picture_format",
    "pt",
    "save",
]

#: Pixels per inch of every picture: with it, 1 pt of line or text is 100 / 72 pixels.
DPI = 100
#: Blank border around everything drawn (pixels).
_MARGIN = 10

PictureFormat = Literal["png", "svg"]


class PixelBox(NamedTuple):
    """(left, top, right, bottom) of a box in picture pixels, origin top left, right and
    bottom exclusive."""

    left: int
    top: int
    right: int
    bottom: int


def picture_format(path: str | Path) -> PictureFormat:
    """The file format a picture path asks for, from its suffix (``.png`` or ``.svg``).

    Raises
    ------
    XfaceValueError
        Any other suffix.

    Examples
    --------
    >>> picture_format("maps/x.SVG")
    'svg'
    """
    suffix = Path(path).suffix.lower()
    if suffix == ".png":
        return "png"
    if suffix == ".svg":
        return "svg"
    raise XfaceValueError(f"{str(path)!r}: a picture file ends in .png or .svg")


def new_figure() -> Figure:
    """An empty figure on its own Agg canvas (sized later by :func:`fit_axes`)."""
    fig = Figure(figsize=(4.0, 3.0), dpi=DPI)
    FigureCanvasAgg(fig)
    return fig


def pt(pixels: float) -> float:
    """A length of ``pixels`` picture pixels in points (line widths, marker sizes)."""
    return pixels * 72.0 / DPI


def fit_axes(fig: Figure, axes: list[tuple[Axes, int, int]], gap: int = 0) -> list[PixelBox]:
    """Size the figure so that axes of exactly the given pixel sizes, side by side from left
    to right ``gap`` pixels apart, and everything they draw (titles, tick labels, legends
    placed outside) fit with a small border.

    Each entry is (axes, width px, height px). The text sizes are measured once in a first
    pass; integer margins keep every axes box on whole pixels, so a cell of ``s`` pixels
    fills exactly ``s`` picture pixels.

    Returns
    -------
    list of PixelBox
        Where each axes' data area lies in the saved picture.
    """
    renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
    heights = [h for _, _, h in axes]
    height = max(heights)
    # First pass: any position; the extra room every axes' decorations take, in pixels.
    fig.set_size_inches(20.0, 20.0)
    extra = []
    for ax, w, h in axes:
        ax.set_position((0.25, 0.25, w / (20.0 * DPI), h / (20.0 * DPI)))
    for ax, _, _ in axes:
        box = ax.get_position().transformed(fig.transFigure)
        tight = ax.get_tightbbox(renderer)
        assert tight is not None
        extra.append(
            (
                math.ceil(box.x0 - tight.x0),
                math.ceil(tight.x1 - box.x1),
                math.ceil(tight.y1 - box.y1),
                math.ceil(box.y0 - tight.y0),
            )
        )
    top = _MARGIN + max(e[2] for e in extra)
    bottom = _MARGIN + max(e[3] for e in extra)
    lefts, x = [], _MARGIN
    for (_, w, _), (left_extra, right_extra, _, _) in zip(axes, extra, strict=True):
        x += left_extra
        lefts.append(x)
        x += w + right_extra + gap
    width_px = x - gap + _MARGIN
    height_px = top + height + bottom
    fig.set_size_inches(width_px / DPI, height_px / DPI)
    boxes = []
    for (ax, w, h), left in zip(axes, lefts, strict=True):
        # Axes lower than the tallest are centred vertically.
        y_top = top + (height - h) // 2
        ax.set_position(
            (left / width_px, 1.0 - (y_top + h) / height_px, w / width_px, h / height_px)
        )
        boxes.append(PixelBox(left, y_top, left + w, y_top + h))
    return boxes


def save(fig: Figure, path: str | Path, fmt: PictureFormat | None = None) -> Path:
    """Write the figure as PNG or SVG (``fmt``, default: from the suffix), the same bytes for
    the same figure: no dates or software versions in the metadata, a fixed SVG id salt.

    Raises
    ------
    XfaceValueError
        The suffix is neither .png nor .svg and no ``fmt`` is given.
    OSError
        The file cannot be written.
    """
    out = Path(path)
    kind = picture_format(out) if fmt is None else fmt
    if kind == "svg":
        metadata: dict[str, str | None] = {"Date": None, "Creator": None}
    else:
        metadata = {"Software": None}
    with mpl.rc_context({"svg.hashsalt": "xface", "svg.fonttype": "path"}):
        fig.savefig(out, format=kind, dpi=DPI, metadata=metadata, facecolor="white")
    return out
