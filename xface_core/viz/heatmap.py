"""A design search's criterion over its H/D x r_p grid as a PNG heat map (matplotlib).

Rows are H/D (growing upwards), columns r_p (growing to the right), like the paper's tables
turned so that both axes grow away from the origin; each cell shows its value, the best cell
is outlined, and a colour bar on the right spans the values. Colours run from dark blue
(lowest) to yellow (highest) through a viridis-like ramp, readable in grey and with the
common colour-vision deficiencies.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import numpy.typing as npt
from matplotlib.colors import LinearSegmentedColormap
from matplotlib.patches import Rectangle

from xface_core.errors import XfaceValueError
from xface_core.viz.figures import fit_axes, new_figure, pt, save

__all__ = ["ramp_colors", "save_heatmap_png"]

#: Anchors of the colour ramp (viridis at 0, 1/4, 1/2, 3/4, 1).
_RAMP = np.array(
    [(68, 1, 84), (59, 82, 139), (33, 145, 140), (94, 201, 98), (253, 231, 37)], dtype=np.float64
)

#: Pixels per cell side: room for a four-digit value.
CELL_PX = 44


def ramp_colors(values: npt.ArrayLike) -> npt.NDArray[np.uint8]:
    """RGB colours (..., 3) of values scaled to [0, 1] by their own minimum and maximum
    (all one colour, the ramp's middle, when they are all equal).

    Examples
    --------
    >>> ramp_colors([0, 10]).tolist()
    [[68, 1, 84], [253, 231, 37]]
    """
    v = np.asarray(values, dtype=np.float64)
    lo, hi = float(v.min()), float(v.max())
    t = np.full(v.shape, 0.5) if hi == lo else (v - lo) / (hi - lo)
    pos = t * (len(_RAMP) - 1)
    k = np.minimum(pos.astype(np.int64), len(_RAMP) - 2)
    frac = (pos - k)[..., None]
    rgb = _RAMP[k] * (1.0 - frac) + _RAMP[k + 1] * frac
    return np.asarray(np.rint(rgb), dtype=np.uint8)


def _value_text(value: float, integral: bool) -> str:
    """A cell's label: the integer, or three decimals (a probability)."""
    return f"{int(value)}" if integral else f"{value:.3f}"


def _ink_on(rgb: npt.NDArray[np.uint8]) -> tuple[int, int, int]:
    """Black on light cells, white on dark ones (luma of ITU-R BT.601)."""
    luma = 0.299 * rgb[0] + 0.587 * rgb[1] + 0.114 * rgb[2]
    return (0, 0, 0) if luma > 128 else (255, 255, 255)


def save_heatmap_png(
    values: npt.ArrayLike,
    h_over_d: Sequence[float],
    r_p: Sequence[float],
    path: str | Path,
    *,
    best: tuple[int, int] | None = None,
    title: str = "",
) -> Path:
    """Write ``values`` (rows H/D, columns r_p; integers, or fractions shown to three
    decimals) as a heat map PNG at ``path`` (a matplotlib figure, CELL_PX pixels per cell).

    The axes are the grid's own H/D and r_p values, one cell each (a search's grid need not
    be evenly spaced); ``best`` (row, column) is outlined. Raises :class:`XfaceValueError`
    when the shapes do not agree.

    Examples
    --------
    >>> import tempfile
    >>> from PIL import Image
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     p = save_heatmap_png([[1, 2], [3, 4]], [0.5, 1.0], [0.0, 1.0], Path(tmp) / "h.png")
    ...     Image.open(p).size[0] > 2 * CELL_PX
    True
    """
    grid = np.asarray(values, dtype=np.float64)
    if grid.ndim != 2 or grid.shape != (len(h_over_d), len(r_p)) or grid.size == 0:
        raise XfaceValueError(
            f"values must be (len(h_over_d), len(r_p)) = ({len(h_over_d)}, {len(r_p)}), "
            f"got {grid.shape}"
        )
    integral = bool(np.all(grid == np.round(grid)))
    n, m = grid.shape
    fig = new_figure()
    ax = fig.add_axes((0.1, 0.1, 0.5, 0.5))
    lo, hi = float(grid.min()), float(grid.max())
    cmap = LinearSegmentedColormap.from_list("xface_ramp", _RAMP / 255.0)
    # All values equal: the ramp's middle, as ramp_colors gives it.
    vmin, vmax = (lo - 1.0, hi + 1.0) if hi == lo else (lo, hi)
    mesh = ax.pcolormesh(
        np.arange(m + 1) - 0.5, np.arange(n + 1) - 0.5, grid, cmap=cmap, vmin=vmin, vmax=vmax
    )
    colors = ramp_colors(grid)
    for (i, j), v in np.ndenumerate(grid):
        ax.text(j, i, _value_text(v, integral), ha="center", va="center", fontsize=8,
                color=np.array(_ink_on(colors[i, j])) / 255.0)  # fmt: skip
    if best is not None:
        bi, bj = best
        for color, width in (("black", 4), ("white", 1.5)):  # white inside black: reads on any
            ax.add_patch(Rectangle((bj - 0.5, bi - 0.5), 1.0, 1.0, fill=False,
                                   edgecolor=color, linewidth=pt(width)))  # fmt: skip
    r_labels = [f"{v:.4g}" for v in r_p]
    # Upright labels while they fit in a cell (about 6 characters of 8 pt in CELL_PX).
    upright = max(len(t) for t in r_labels) <= 6
    ax.set_xticks(range(m), r_labels, fontsize=8, rotation=0 if upright else 90)
    ax.set_yticks(range(n), [f"{v:.4g}" for v in h_over_d], fontsize=8)
    ax.set_xlabel("$r_p$ / D", fontsize=10)
    ax.set_ylabel("H / D", fontsize=10)
    if title:
        ax.set_title(title, fontsize=10)
    cax = fig.add_axes((0.7, 0.1, 0.05, 0.5))
    fig.colorbar(mesh, cax=cax).ax.tick_params(labelsize=8)
    fit_axes(fig, [(ax, m * CELL_PX, n * CELL_PX), (cax, 16, n * CELL_PX)], gap=12)
    return save(fig, path, "png")
