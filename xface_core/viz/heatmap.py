"""A design search's criterion over its H/D x r_p grid as a PNG heat map (pillow).

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
from PIL import Image, ImageDraw, ImageFont

from xface_core.errors import XfaceValueError

__all__ = ["ramp_colors", "save_heatmap_png"]

#: Anchors of the colour ramp (viridis at 0, 1/4, 1/2, 3/4, 1).
_RAMP = np.array(
    [(68, 1, 84), (59, 82, 139), (33, 145, 140), (94, 201, 98), (253, 231, 37)], dtype=np.float64
)

_PAD = 8
_INK = (0, 0, 0)
_PAPER = (255, 255, 255)

_Font = ImageFont.FreeTypeFont | ImageFont.ImageFont


def _font(size: int) -> _Font:
    # Pillow's bundled font (no system fonts needed on a bare machine).
    return ImageFont.load_default(size=size)


def _text_size(font: _Font, text: str) -> tuple[int, int]:
    left, top, right, bottom = font.getbbox(text)
    return int(np.ceil(right - left)), int(np.ceil(bottom - top))


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
    decimals) as a heat map PNG at ``path``.

    ``best`` (row, column) is outlined. Raises :class:`XfaceValueError` when the shapes do
    not agree.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     p = save_heatmap_png([[1, 2], [3, 4]], [0.5, 1.0], [0.0, 1.0], Path(tmp) / "h.png")
    ...     Image.open(p).size[0] > 2 * CELL_PX
    True
    """
    grid = np.asarray(values, dtype=np.float64)
    integral = bool(np.all(grid == np.round(grid)))
    if grid.ndim != 2 or grid.shape != (len(h_over_d), len(r_p)) or grid.size == 0:
        raise XfaceValueError(
            f"values must be (len(h_over_d), len(r_p)) = ({len(h_over_d)}, {len(r_p)}), "
            f"got {grid.shape}"
        )
    n, m = grid.shape
    font, title_font = _font(13), _font(16)
    line_h = _text_size(font, "Ag")[1] + 4
    row_labels = [f"{h:.5g}" for h in h_over_d]
    left = 2 * _PAD + line_h + max(_text_size(font, s)[0] for s in row_labels)
    top = 3 * _PAD + _text_size(title_font, title or "Ag")[1]
    right, bottom = left + m * CELL_PX, top + n * CELL_PX
    bar_x = right + 3 * _PAD
    top_text, bottom_text = (_value_text(v, integral) for v in (grid.max(), grid.min()))
    width = max(bar_x + 20 + _PAD + _text_size(font, top_text)[0] + 2 * _PAD, right)
    image = Image.new("RGB", (width, bottom + 2 * line_h + 2 * _PAD), _PAPER)
    draw = ImageDraw.Draw(image)
    draw.text((left, _PAD), title, font=title_font, fill=_INK)
    colors = ramp_colors(grid)
    for i in range(n):
        y0 = top + (n - 1 - i) * CELL_PX  # H/D grows upwards
        tw, th = _text_size(font, row_labels[i])
        draw.text((left - _PAD - tw, y0 + (CELL_PX - th) // 2), row_labels[i], font=font, fill=_INK)
        for j in range(m):
            x0 = left + j * CELL_PX
            rgb = colors[i, j]
            draw.rectangle((x0, y0, x0 + CELL_PX - 1, y0 + CELL_PX - 1), fill=tuple(rgb.tolist()))
            text = _value_text(grid[i, j], integral)
            tw, th = _text_size(font, text)
            xy = (x0 + (CELL_PX - tw) // 2, y0 + (CELL_PX - th) // 2 - 2)
            draw.text(xy, text, font=font, fill=_ink_on(rgb))
    for j, rp in enumerate(r_p):
        label = f"{rp:.5g}"
        tw, _ = _text_size(font, label)
        draw.text(
            (left + j * CELL_PX + (CELL_PX - tw) // 2, bottom + 2), label, font=font, fill=_INK
        )
    draw.text((left, bottom + line_h + 2), "r_p / D (columns), H/D (rows)", font=font, fill=_INK)
    if best is not None:
        bi, bj = best
        x0, y0 = left + bj * CELL_PX, top + (n - 1 - bi) * CELL_PX
        draw.rectangle((x0, y0, x0 + CELL_PX - 1, y0 + CELL_PX - 1), outline=_INK, width=3)
        draw.rectangle((x0 + 3, y0 + 3, x0 + CELL_PX - 4, y0 + CELL_PX - 4), outline=_PAPER)
    ramp = ramp_colors(np.linspace(1.0, 0.0, bottom - top))  # top of the bar: the maximum
    image.paste(Image.fromarray(np.repeat(ramp[:, None, :], 20, axis=1)), (bar_x, top))
    draw.text((bar_x + 20 + _PAD, top), top_text, font=font, fill=_INK)
    _, th = _text_size(font, bottom_text)
    draw.text((bar_x + 20 + _PAD, bottom - th - 4), bottom_text, font=font, fill=_INK)
    out = Path(path)
    image.save(out, format="PNG")
    return out
