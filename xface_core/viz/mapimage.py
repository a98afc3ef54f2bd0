"""Acceptance maps as pictures: one fixed colour per outcome, PNG files with axes and a legend.

An acceptance map holds one :class:`~xface_core.outcome.Outcome` per initial pose on a grid:
rows are lateral offsets ``x0`` (increasing), columns initial angles ``theta0`` (increasing).
In every picture made here **theta0 runs along the horizontal axis (left to right) and x0 up
the vertical axis (bottom to top)**, so the first grid row is the picture's bottom row.

Any object with the attributes of :class:`AcceptanceMapLike` can be drawn; the map type of
:mod:`xface_core.sweep` is one. This module needs only numpy and pillow (no rerun);
:func:`checked_grid` is the one check of a map's shape and values, shared with the rerun
recordings of :mod:`xface_core.viz.recording`.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, NamedTuple, Protocol, TypeAlias

import numpy as np
import numpy.typing as npt
from PIL import Image, ImageDraw, ImageFont

from xface_core.errors import XfaceValueError
from xface_core.geometry import FaceDesign
from xface_core.outcome import Outcome

__all__ = [
    "AcceptanceMapLike",
    "MapPicture",
    "checked_grid",
    "guaranteed_cells",
    "map_to_rgb",
    "outcome_colors",
    "save_map_png",
]

RGB = tuple[int, int, int]

# Okabe-Ito colours (distinguishable with the common colour-vision deficiencies); SEATED is
# the green that the eye reads as "good", the failure modes are warm, the "not simulated"
# outcomes are greys.
_COLORS: dict[Outcome, RGB] = {
    Outcome.INVALID_INPUT: (64, 64, 64),
    Outcome.OUT_OF_REACH: (190, 190, 190),
    Outcome.NO_CONTACT: (86, 180, 233),
    Outcome.SEATED: (0, 158, 115),
    Outcome.BAD_MATE: (213, 94, 0),
    Outcome.PASSED: (230, 159, 0),
    Outcome.UNRESOLVED: (204, 121, 167),
}

#: Outline colour of the guaranteed-acceptance rectangle (black reads on every cell colour).
GUARANTEED_OUTLINE: RGB = (0, 0, 0)


class AcceptanceMapLike(Protocol):
    """What a map must offer to be drawn or recorded (the sweep's map type has all of it).

    Attributes
    ----------
    x0 : (n,) float array
        Lateral offsets of the rows, strictly increasing, in the design's length unit.
    theta0 : (m,) float array
        Initial angles of the columns, strictly increasing (rad).
    outcomes : (n, m) int array
        :class:`~xface_core.outcome.Outcome` value per grid pose.
    M : int
        Number of SEATED cells.
    design : FaceDesign
        The connector the map was computed for.
    guaranteed : object or None
        The largest all-SEATED axis-aligned rectangle as index ranges (see
        :func:`guaranteed_cells` for the accepted forms), or None.
    """

    @property
    def x0(self) -> npt.NDArray[np.floating[Any]]: ...

    @property
    def theta0(self) -> npt.NDArray[np.floating[Any]]: ...

    @property
    def outcomes(self) -> npt.NDArray[np.integer[Any]]: ...

    @property
    def M(self) -> int: ...

    @property
    def design(self) -> FaceDesign: ...

    @property
    def guaranteed(self) -> object: ...


class MapPicture(NamedTuple):
    """Where :func:`save_map_png` wrote its picture and where the cells are in it."""

    path: Path
    """The PNG file."""
    size: tuple[int, int]
    """(width, height) of the picture in pixels."""
    cells: tuple[int, int, int, int]
    """(left, top, right, bottom) pixel box of the grid cells (right/bottom exclusive)."""


def outcome_colors() -> dict[Outcome, RGB]:
    """The fixed RGB colour of every outcome (a fresh dict: changing it changes nothing).

    Examples
    --------
    >>> colors = outcome_colors()
    >>> colors[Outcome.SEATED]
    (0, 158, 115)
    >>> len(set(colors.values())) == len(Outcome)
    True
    """
    return dict(_COLORS)


def checked_grid(
    amap: AcceptanceMapLike,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.int64]]:
    """The map's axes and outcomes as plain arrays, or a clear error saying what is wrong.

    Every picture and recording of a map starts here.

    Returns
    -------
    (x0, theta0, outcomes) : (n,) float, (m,) float, (n, m) int64 arrays

    Raises
    ------
    XfaceValueError
        The axes are not non-empty, finite and strictly increasing, or the outcomes do not
        match them in shape or hold a value that is not an :class:`Outcome`.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> amap = SimpleNamespace(x0=[0.0, 1.0], theta0=[0.0], outcomes=[[3], [9]])
    >>> checked_grid(amap)
    Traceback (most recent call last):
    ...
    xface_core.errors.XfaceValueError: map holds 9, which is not an Outcome value
    """
    x0 = np.asarray(amap.x0, dtype=np.float64)
    theta0 = np.asarray(amap.theta0, dtype=np.float64)
    raw = np.asarray(amap.outcomes)
    if x0.ndim != 1 or theta0.ndim != 1 or x0.size == 0 or theta0.size == 0:
        raise XfaceValueError("map axes x0 and theta0 must be non-empty 1-D arrays")
    if raw.shape != (x0.size, theta0.size):
        raise XfaceValueError(
            f"map outcomes have shape {raw.shape}, expected (len(x0), len(theta0)) = "
            f"{(x0.size, theta0.size)}"
        )
    if not (np.all(np.isfinite(x0)) and np.all(np.isfinite(theta0))):
        raise XfaceValueError("map axes must be finite")
    if np.any(np.diff(x0) <= 0.0) or np.any(np.diff(theta0) <= 0.0):
        raise XfaceValueError("map axes x0 and theta0 must be strictly increasing")
    if not np.issubdtype(raw.dtype, np.integer):
        raise XfaceValueError(f"map outcomes must be integers, got dtype {raw.dtype}")
    outcomes = raw.astype(np.int64)
    valid = np.isin(outcomes, [int(o) for o in Outcome])
    if not np.all(valid):
        bad = int(outcomes[~valid][0])
        raise XfaceValueError(f"map holds {bad}, which is not an Outcome value")
    return x0, theta0, outcomes


def guaranteed_cells(amap: AcceptanceMapLike) -> tuple[int, int, int, int] | None:
    """The guaranteed-acceptance rectangle as half-open grid index ranges, or None.

    ``amap.guaranteed`` may be None, a pair of slices ``(rows, cols)``, a pair of ranges, or a
    pair of ``(start, stop)`` integer pairs; all are read half-open, the Python way (the
    rectangle covers ``outcomes[row_start:row_stop, col_start:col_stop]``).

    Returns
    -------
    (row_start, row_stop, col_start, col_stop) or None

    Raises
    ------
    XfaceValueError
        The rectangle is empty, leaves the grid, or covers a cell that is not SEATED.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> from xface_core import x_face
    >>> grid = np.full((3, 4), int(Outcome.SEATED))
    >>> amap = SimpleNamespace(
    ...     x0=np.arange(3.0),
    ...     theta0=np.arange(4.0),
    ...     outcomes=grid,
    ...     M=12,
    ...     design=x_face(0.25, 1.0),
    ...     guaranteed=(slice(0, 2), slice(1, 4)),
    ... )
    >>> guaranteed_cells(amap)
    (0, 2, 1, 4)
    """
    _, _, outcomes = checked_grid(amap)
    g = amap.guaranteed
    if g is None:
        return None
    try:
        if not isinstance(g, tuple | list) or len(g) != 2:
            raise TypeError("not a pair")
        bounds = [_half_open(g[0]), _half_open(g[1])]
    except (TypeError, ValueError):
        raise XfaceValueError(
            f"map.guaranteed must be None or (rows, cols) index ranges, got {g!r}"
        ) from None
    (r0, r1), (c0, c1) = bounds
    n, m = outcomes.shape
    if not (0 <= r0 < r1 <= n and 0 <= c0 < c1 <= m):
        raise XfaceValueError(
            f"guaranteed rectangle rows {r0}:{r1}, columns {c0}:{c1} is empty or leaves the "
            f"{n} x {m} grid"
        )
    if np.any(outcomes[r0:r1, c0:c1] != int(Outcome.SEATED)):
        raise XfaceValueError("the guaranteed rectangle covers cells that are not SEATED")
    return r0, r1, c0, c1


def _half_open(index_range: object) -> tuple[int, int]:
    if isinstance(index_range, slice):
        if index_range.step not in (None, 1):
            raise ValueError("step")
        return int(index_range.start or 0), int(index_range.stop)
    if isinstance(index_range, range):
        if index_range.step != 1:
            raise ValueError("step")
        return index_range.start, index_range.stop
    if not isinstance(index_range, tuple | list) or len(index_range) != 2:
        raise TypeError("an index range is a slice, a range or a (start, stop) pair")
    start, stop = index_range
    for bound in (start, stop):
        if isinstance(bound, bool) or not isinstance(bound, int | np.integer):
            raise TypeError("index ranges take integers")
    return int(start), int(stop)


def _check_scale(scale: object) -> int:
    if isinstance(scale, bool) or not isinstance(scale, int | np.integer) or not 1 <= scale <= 64:
        raise XfaceValueError(f"scale must be an integer in 1..64 (pixels per cell), got {scale!r}")
    return int(scale)


def map_to_rgb(amap: AcceptanceMapLike, *, scale: int = 8) -> npt.NDArray[np.uint8]:
    """The map's cells as an RGB picture, ``scale`` x ``scale`` pixels per cell.

    theta0 runs left to right, x0 bottom to top: picture row 0 is the grid's last row (the
    largest x0). Colours are :func:`outcome_colors`.

    Parameters
    ----------
    amap : AcceptanceMapLike
        The map (n rows of x0, m columns of theta0).
    scale : int
        Pixels per cell side, 1..64.

    Returns
    -------
    (n * scale, m * scale, 3) uint8 array

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> from xface_core import x_face
    >>> grid = np.array([[int(Outcome.SEATED), int(Outcome.PASSED)]] * 3)
    >>> amap = SimpleNamespace(
    ...     x0=np.array([-1.0, 0.0, 1.0]),
    ...     theta0=np.array([-0.5, 0.5]),
    ...     outcomes=grid,
    ...     M=3,
    ...     design=x_face(0.25, 1.0),
    ...     guaranteed=None,
    ... )
    >>> rgb = map_to_rgb(amap, scale=4)
    >>> rgb.shape
    (12, 8, 3)
    >>> tuple(int(c) for c in rgb[0, 7])  # top right: largest x0, largest theta0
    (230, 159, 0)
    """
    scale = _check_scale(scale)
    _, _, outcomes = checked_grid(amap)
    lut = np.zeros((len(Outcome), 3), dtype=np.uint8)
    for outcome, color in _COLORS.items():
        lut[int(outcome)] = color
    cells = lut[outcomes[::-1]]  # flip rows: x0 grows upwards
    return np.repeat(np.repeat(cells, scale, axis=0), scale, axis=1)


# --- the PNG ----------------------------------------------------------------------------------

_FONT_PX = 13
_PAD = 8
_TICK = 4
_INK: RGB = (0, 0, 0)
_PAPER: RGB = (255, 255, 255)

_Font: TypeAlias = ImageFont.FreeTypeFont | ImageFont.ImageFont
#: (grid index, value) per tick.
_Ticks: TypeAlias = list[tuple[int, float]]
#: (text, swatch colour, outlined like the guaranteed rectangle) per legend row.
_LegendEntry: TypeAlias = tuple[str, RGB, bool]


def _font(size: int) -> _Font:
    # Pillow's bundled font (no system fonts needed on a bare machine); it covers ASCII only,
    # so labels say "theta0" and "-" rather than the Greek letter and the minus sign.
    return ImageFont.load_default(size=size)


def _text_size(font: _Font, text: str) -> tuple[int, int]:
    left, top, right, bottom = font.getbbox(text)
    return math.ceil(right - left), math.ceil(bottom - top)


def _ticks(values: npt.NDArray[np.float64], nice: list[float]) -> _Ticks:
    """Grid indices and values of the ``nice`` tick values that lie on the axis (within half
    a cell); the axis ends when fewer than two do."""
    half = 0.5 * float(np.min(np.diff(values))) if values.size > 1 else 0.5
    chosen: _Ticks = []
    for v in nice:
        i = int(np.argmin(np.abs(values - v)))
        if abs(values[i] - v) <= half and all(i != j for j, _ in chosen):
            chosen.append((i, v))
    if len(chosen) < 2:
        chosen = [(0, float(values[0])), (values.size - 1, float(values[-1]))]
    return chosen


def _tick_label(v: float) -> str:
    text = f"{v:.3g}"
    return "0" if text in ("-0", "0.0", "-0.0") else text


def _default_title(design: FaceDesign) -> str:
    if design.kind == "custom":
        return f"custom face, L = {design.mated_distance:g} D"
    return f"{design.kind}-Face, H/D = {design.h_over_d:g}, r_p = {design.r_p:g} D"


class _Layout(NamedTuple):
    """Where everything goes in the PNG (pixels)."""

    left: int
    """First pixel column of the cells."""
    top: int
    """First pixel row of the cells."""
    right: int
    """Pixel column just after the cells."""
    bottom: int
    """Pixel row just after the cells."""
    width: int
    height: int
    line_h: int
    """Height of one line of label text, and of one legend row."""
    swatch: int
    """Side of a legend colour swatch."""
    n: int
    """Grid rows (x0)."""
    scale: int
    """Pixels per cell side."""


def _counts(amap: AcceptanceMapLike, outcomes: npt.NDArray[np.int64]) -> dict[Outcome, int]:
    """Cells per outcome; ``amap.M`` must be the SEATED count."""
    counts = {o: int(np.count_nonzero(outcomes == int(o))) for o in Outcome}
    if int(amap.M) != counts[Outcome.SEATED]:
        raise XfaceValueError(
            f"map.M = {amap.M} but the grid has {counts[Outcome.SEATED]} SEATED cells"
        )
    return counts


def _axis_ticks(
    x0: npt.NDArray[np.float64], theta0: npt.NDArray[np.float64], width_unit: float, scale: int
) -> tuple[_Ticks, _Ticks]:
    """Ticks of x0 / D (vertical axis) and of theta0 in degrees (horizontal axis)."""
    x_ticks = _ticks(x0 / width_unit, [-1.0, -0.5, 0.0, 0.5, 1.0])
    t_ticks = _ticks(np.degrees(theta0), [-90.0, -60.0, -30.0, 0.0, 30.0, 60.0, 90.0])
    if len(t_ticks) > 2 and theta0.size * scale < 240:  # keep the labels apart on small pictures
        t_ticks = t_ticks[::2]
    return x_ticks, t_ticks


def _legend(
    counts: dict[Outcome, int], rect: tuple[int, int, int, int] | None
) -> list[_LegendEntry]:
    """One entry per outcome with its count, then the guaranteed rectangle's size."""
    legend = [
        (f"{o.name.lower().replace('_', ' ')}: {counts[o]}", _COLORS[o], False) for o in Outcome
    ]
    if rect is None:
        legend.append(("guaranteed: none", _PAPER, True))
    else:
        r0, r1, c0, c1 = rect
        legend.append((f"guaranteed: {r1 - r0} x {c1 - c0}", _PAPER, True))
    return legend


def _layout(
    font: _Font,
    title_font: _Font,
    heading: str,
    x_ticks: _Ticks,
    legend_rows: int,
    shape: tuple[int, int],
    scale: int,
) -> _Layout:
    """Title on top, x0 labels on the left, theta0 labels below, legend right."""
    n, m = shape
    tick_w = max(_text_size(font, _tick_label(v))[0] for _, v in x_ticks)
    line_h = _text_size(font, "Ag")[1] + 4
    left = _PAD + line_h + _PAD + tick_w + _TICK + 2
    top = _PAD + _text_size(title_font, heading)[1] + 2 * _PAD
    swatch = line_h - 3
    # Sized for the widest possible entries, so every map of a grid size has one layout.
    widest = [f"{o.name.lower().replace('_', ' ')}: {n * m}" for o in Outcome]
    widest.append(f"guaranteed: {n} x {m}")
    legend_w = max(_text_size(font, text)[0] for text in widest) + swatch + 3 * _PAD
    right = left + m * scale
    bottom = top + n * scale
    width = max(right + 2 * _PAD + legend_w, left + _text_size(title_font, heading)[0] + _PAD)
    height = max(bottom + _TICK + 2 * line_h + 2 * _PAD, top + legend_rows * line_h + _PAD)
    return _Layout(left, top, right, bottom, width, height, line_h, swatch, n, scale)


def _draw_guaranteed(
    draw: ImageDraw.ImageDraw, lay: _Layout, rect: tuple[int, int, int, int]
) -> None:
    """Outline the guaranteed rectangle's cells (inside their pixel box)."""
    r0, r1, c0, c1 = rect
    left, top, n, scale = lay.left, lay.top, lay.n, lay.scale
    # Rows are flipped in the picture: grid row r spans y from top + (n - 1 - r) * scale.
    box = (left + c0 * scale, top + (n - r1) * scale, left + c1 * scale, top + (n - r0) * scale)
    draw.rectangle(
        (box[0], box[1], box[2] - 1, box[3] - 1),
        outline=GUARANTEED_OUTLINE,
        width=max(1, min(3, scale // 3)),
    )


def _draw_ticks(
    draw: ImageDraw.ImageDraw, font: _Font, lay: _Layout, x_ticks: _Ticks, t_ticks: _Ticks
) -> None:
    """Tick marks and their values: x0 on the left edge, theta0 below the cells."""
    left, top, n, scale = lay.left, lay.top, lay.n, lay.scale
    for i, v in x_ticks:
        y = top + (n - 1 - i) * scale + scale // 2
        draw.line((left - 1 - _TICK, y, left - 1, y), fill=_INK)
        label = _tick_label(v)
        tw, th = _text_size(font, label)
        draw.text((left - 2 - _TICK - 2 - tw, y - th // 2 - 2), label, font=font, fill=_INK)
    for j, v in t_ticks:
        x = left + j * scale + scale // 2
        draw.line((x, lay.bottom, x, lay.bottom + _TICK), fill=_INK)
        label = _tick_label(v)
        tw, _ = _text_size(font, label)
        draw.text((x - tw // 2, lay.bottom + _TICK + 2), label, font=font, fill=_INK)


def _draw_axis_names(
    image: Image.Image, draw: ImageDraw.ImageDraw, font: _Font, lay: _Layout
) -> None:
    """ "theta0 (deg)" centred below the ticks, "x0 / D" turned upright left of the cells."""
    x_label = "theta0 (deg)"
    tw, _ = _text_size(font, x_label)
    draw.text(
        (lay.left + (lay.right - lay.left - tw) // 2, lay.bottom + _TICK + lay.line_h + 2),
        x_label,
        font=font,
        fill=_INK,
    )
    y_label = "x0 / D"
    tw, _ = _text_size(font, y_label)
    label_img = Image.new("RGB", (tw + 4, lay.line_h), _PAPER)
    ImageDraw.Draw(label_img).text((2, 0), y_label, font=font, fill=_INK)
    rotated = label_img.rotate(90, expand=True)
    image.paste(rotated, (_PAD, lay.top + (lay.bottom - lay.top - rotated.height) // 2))


def _draw_legend(
    draw: ImageDraw.ImageDraw, font: _Font, lay: _Layout, legend: list[_LegendEntry]
) -> None:
    """A swatch and its text per entry, one line each, right of the cells."""
    lx = lay.right + 2 * _PAD
    swatch = lay.swatch
    for k, (text, color, outlined) in enumerate(legend):
        y = lay.top + k * lay.line_h
        if outlined:
            draw.rectangle(
                (lx, y, lx + swatch, y + swatch), fill=color, outline=GUARANTEED_OUTLINE, width=2
            )
        else:
            draw.rectangle((lx, y, lx + swatch, y + swatch), fill=color, outline=(90, 90, 90))
        draw.text((lx + swatch + _PAD, y), text, font=font, fill=_INK)


def save_map_png(
    amap: AcceptanceMapLike,
    path: str | Path,
    *,
    scale: int = 8,
    title: str | None = None,
) -> MapPicture:
    """Write the map as a PNG: coloured cells, axes, legend with counts, M in the title.

    Layout: theta0 (degrees) on the horizontal axis, x0 / D on the vertical axis (x0 grows
    upwards), the guaranteed-acceptance rectangle outlined in black, a legend on the right
    with the colour and the number of cells of every outcome.

    Parameters
    ----------
    amap : AcceptanceMapLike
        The map to draw.
    path : str or Path
        Where to write the PNG (the parent folder must exist).
    scale : int
        Pixels per cell side, 1..64.
    title : str, optional
        The title's text; ``M = ...`` (and the grid size) is always appended. Default: the
        design ("X-Face, H/D = 0.25, r_p = 1 D").

    Returns
    -------
    MapPicture
        The path, the picture's size and the pixel box of the cells.

    Raises
    ------
    XfaceValueError
        The map is malformed (see :func:`guaranteed_cells`), ``amap.M`` disagrees with the
        number of SEATED cells, or ``scale`` is out of range.

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
    ...     picture = save_map_png(amap, Path(tmp) / "map.png", scale=4)
    >>> picture.cells[2] - picture.cells[0], picture.cells[3] - picture.cells[1]
    (28, 20)
    """
    scale = _check_scale(scale)
    x0, theta0, outcomes = checked_grid(amap)
    rect = guaranteed_cells(amap)
    counts = _counts(amap, outcomes)
    design = amap.design
    n, m = outcomes.shape

    font = _font(_FONT_PX)
    title_font = _font(_FONT_PX + 3)
    x_ticks, t_ticks = _axis_ticks(x0, theta0, design.width, scale)
    heading = f"{title if title is not None else _default_title(design)}   M = {amap.M} / {n * m}"
    legend = _legend(counts, rect)
    lay = _layout(font, title_font, heading, x_ticks, len(legend), (n, m), scale)

    image = Image.new("RGB", (lay.width, lay.height), _PAPER)
    image.paste(Image.fromarray(map_to_rgb(amap, scale=scale), mode="RGB"), (lay.left, lay.top))
    draw = ImageDraw.Draw(image)
    draw.rectangle((lay.left - 1, lay.top - 1, lay.right, lay.bottom), outline=_INK)
    draw.text((lay.left, _PAD), heading, font=title_font, fill=_INK)
    if rect is not None:
        _draw_guaranteed(draw, lay, rect)
    _draw_ticks(draw, font, lay, x_ticks, t_ticks)
    _draw_axis_names(image, draw, font, lay)
    _draw_legend(draw, font, lay, legend)

    out = Path(path)
    image.save(out, format="PNG")
    return MapPicture(
        path=out, size=(lay.width, lay.height), cells=(lay.left, lay.top, lay.right, lay.bottom)
    )
