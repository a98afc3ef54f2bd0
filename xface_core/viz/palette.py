"""The colours every picture and recording draws with: Okabe and Ito's palette, told apart
with each common colour-vision deficiency (Okabe & Ito, "Color Universal Design", 2008), as
8-bit RGB. No dependency: the pictures (matplotlib), the recordings (rerun) and the map
images all read their colours here, so a part, an outcome or a phase has one colour
everywhere.
"""

from __future__ import annotations

RGB = tuple[int, int, int]

BLACK: RGB = (0, 0, 0)
ORANGE: RGB = (230, 159, 0)
SKY_BLUE: RGB = (86, 180, 233)
BLUISH_GREEN: RGB = (0, 158, 115)
YELLOW: RGB = (240, 228, 66)
BLUE: RGB = (0, 114, 178)
VERMILLION: RGB = (213, 94, 0)
REDDISH_PURPLE: RGB = (204, 121, 167)

#: Per layer (layer k takes k % 2): the base in blue and sky blue, the moving part in
#: vermillion and orange.
BASE_LAYERS: tuple[RGB, RGB] = (BLUE, SKY_BLUE)
MOVING_LAYERS: tuple[RGB, RGB] = (VERMILLION, ORANGE)


def hex_color(rgb: RGB) -> str:
    """``rgb`` as matplotlib's ``#rrggbb``."""
    return "#{:02x}{:02x}{:02x}".format(*rgb)
