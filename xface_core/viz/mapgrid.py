"""Acceptance maps as data to draw: one fixed colour per outcome, the checks of a map's shape
and values, its guaranteed region as grid indices, and its cells as an RGB array.

An acceptance map holds one :class:`~xface_core.codes.Outcome` per initial pose on a grid:
rows are lateral offsets ``x0`` (increasing), columns initial angles ``theta0`` (increasing).
In every picture **theta0 runs along the horizontal axis (left to right) and x0 up the
vertical axis (bottom to top)**, so the first grid row is the picture's bottom row.

Any object with the attributes of :class:`AcceptanceMapLike` can be drawn; the map type of
:mod:`xface_core.maps.acceptance` is one. numpy only: the figures (:mod:`xface_core.viz.mapimage`,
matplotlib) and the rerun recordings (:mod:`xface_core.viz.recording`) both start here.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, NamedTuple, Protocol, cast

import numpy as np
import numpy.typing as npt

from xface_core.codes import Outcome
from xface_core.errors import XfaceValueError, is_integer_in
from xface_core.geometry import FaceDesign
from xface_core.viz import palette

__all__ = [
    "GUARANTEED_OUTLINE",
    "AcceptanceMapLike",
    "MapPicture",
    "checked_grid",
    "guaranteed_cells",
    "map_to_rgb",
    "outcome_colors",
    "region_cells",
]

RGB = palette.RGB

# Okabe-Ito colours (distinguishable with the common colour-vision deficiencies); SEATED is
# the green that the eye reads as "good", the failure modes are warm, the "not simulated"
# outcomes are greys.
_COLORS: dict[Outcome, RGB] = {
    Outcome.INVALID_INPUT: (64, 64, 64),
    Outcome.OUT_OF_REACH: (190, 190, 190),
    Outcome.NO_CONTACT: palette.SKY_BLUE,
    Outcome.SEATED: palette.BLUISH_GREEN,
    Outcome.BAD_MATE: palette.VERMILLION,
    Outcome.PASSED: palette.ORANGE,
    Outcome.UNRESOLVED: palette.REDDISH_PURPLE,
}

#: Outline colour of the guaranteed-acceptance rectangle (black reads on every cell colour).
GUARANTEED_OUTLINE: RGB = palette.BLACK


class AcceptanceMapLike(Protocol):
    """What a map must offer to be drawn or recorded (the sweep's map type has all of it).

    Attributes
    ----------
    x0 : (n,) float array
        Lateral offsets of the rows, strictly increasing, in the design's length unit.
    theta0 : (m,) float array
        Initial angles of the columns, strictly increasing (rad).
    outcomes : (n, m) int array
        :class:`~xface_core.codes.Outcome` value per grid pose.
    M : int
        Number of SEATED cells.
    design : FaceDesign
        The connector the map was computed for.
    guaranteed : object or None
        The largest all-SEATED axis-aligned rectangle as index ranges (see
        :func:`guaranteed_cells` for the accepted forms), or None.

    A map may also have ``centred`` (the largest all-SEATED rectangle centred on the
    aligned pose, in the same forms); the pictures draw it where it differs.
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
    """Where :func:`~xface_core.viz.mapimage.save_map_picture` wrote its picture and where
    the cells are in it."""

    path: Path
    """The picture file (PNG or SVG)."""
    size: tuple[int, int]
    """(width, height) of the picture in pixels (an SVG's at 100 pixels per inch)."""
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
    return region_cells(outcomes, amap.guaranteed, "guaranteed")


def region_cells(
    outcomes: npt.NDArray[np.int64], g: object, name: str
) -> tuple[int, int, int, int] | None:
    """A region given as (rows, cols) index ranges (the forms of :func:`guaranteed_cells`),
    checked against the grid as (row_start, row_stop, col_start, col_stop), or None;
    ``name`` is the attribute it came from, for the messages."""
    if g is None:
        return None
    try:
        if not isinstance(g, tuple | list) or len(g) != 2:
            raise TypeError("not a pair")
        bounds = [_half_open(g[0]), _half_open(g[1])]
    except (TypeError, ValueError):
        raise XfaceValueError(
            f"map.{name} must be None or (rows, cols) index ranges, got {g!r}"
        ) from None
    (r0, r1), (c0, c1) = bounds
    n, m = outcomes.shape
    if not (0 <= r0 < r1 <= n and 0 <= c0 < c1 <= m):
        raise XfaceValueError(
            f"{name} rectangle rows {r0}:{r1}, columns {c0}:{c1} is empty or leaves the "
            f"{n} x {m} grid"
        )
    if np.any(outcomes[r0:r1, c0:c1] != int(Outcome.SEATED)):
        raise XfaceValueError(f"the {name} rectangle covers cells that are not SEATED")
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


def check_scale(scale: object) -> int:
    """``scale`` (pixels per cell side) as an int in 1..64, or an XfaceValueError."""
    if not is_integer_in(scale, 1, 64):
        raise XfaceValueError(f"scale must be an integer in 1..64 (pixels per cell), got {scale!r}")
    return int(cast(int, scale))


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
    scale = check_scale(scale)
    _, _, outcomes = checked_grid(amap)
    lut = np.zeros((len(Outcome), 3), dtype=np.uint8)
    for outcome, color in _COLORS.items():
        lut[int(outcome)] = color
    cells = lut[outcomes[::-1]]  # flip rows: x0 grows upwards
    return np.repeat(np.repeat(cells, scale, axis=0), scale, axis=1)
