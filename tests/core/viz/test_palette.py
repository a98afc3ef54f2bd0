"""xface_core.viz.palette: one colour per part, outcome and phase in every picture and recording."""

from __future__ import annotations

import pytest

from xface_core.codes import Outcome
from xface_core.viz import palette


def test_hex_color_writes_matplotlib_s_rrggbb() -> None:
    assert palette.hex_color(palette.BLUE) == "#0072b2"
    assert palette.hex_color(palette.BLACK) == "#000000"


def test_the_pictures_and_the_recordings_draw_the_parts_in_the_same_colours() -> None:
    pytest.importorskip("matplotlib")
    pytest.importorskip("rerun")
    from xface_core.viz import facedraw, recording

    for part, layers in (("base", recording._BASE_COLORS), ("moving", recording._MOVING_COLORS)):
        assert facedraw._PART_COLORS[part] == tuple(palette.hex_color(c) for c in layers)


def test_a_map_and_its_comparison_draw_seated_in_the_same_green() -> None:
    pytest.importorskip("matplotlib")
    from xface_core.viz import comparefig, mapgrid

    both = comparefig.DIFFERENCE_COLORS[comparefig.SeatedIn.BOTH]
    assert both == mapgrid._COLORS[Outcome.SEATED] == palette.BLUISH_GREEN
