"""Two maps compared cell by cell: the counts, and maps that do not share a grid."""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import numpy.typing as npt
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from matplotlib.figure import Figure
from matplotlib.legend import Legend
from matplotlib.text import Text

from xface_core.codes import Outcome
from xface_core.errors import XfaceValueError
from xface_core.geometry import x_face
from xface_core.maps.grids import x0_grid
from xface_core.viz import comparefig
from xface_core.viz.comparefig import save_comparison
from xface_core.viz.mapdiff import SeatedIn, map_difference

S, B, P = int(Outcome.SEATED), int(Outcome.BAD_MATE), int(Outcome.PASSED)


def make_map(grid: list[list[int]] | npt.NDArray[np.int64], width: float = 1.0) -> SimpleNamespace:
    g = np.asarray(grid, dtype=np.int64)
    return SimpleNamespace(
        x0=x0_grid(g.shape[0]) * width if g.shape[0] % 2 else np.linspace(-1.0, 1.0, g.shape[0]),
        theta0=np.linspace(-math.pi / 2, math.pi / 2, g.shape[1]),
        outcomes=g,
        M=int(np.count_nonzero(g == S)),
        design=x_face(0.25, 1.0, width=width),
        guaranteed=None,
    )


A = make_map([[S, S, B], [S, B, B]])
B_MAP = make_map([[S, B, S], [P, B, B]])


def test_counts_of_a_hand_made_pair() -> None:
    diff = map_difference(A, B_MAP)
    assert diff.counts() == {
        SeatedIn.BOTH: 1,
        SeatedIn.ONLY_A: 2,
        SeatedIn.ONLY_B: 1,
        SeatedIn.NEITHER: 2,
    }


def test_same_outcome_counts_failures_too() -> None:
    assert map_difference(A, B_MAP).same_outcome == 3  # (0,0) seated, (1,1) and (1,2) bad


def test_maps_on_different_grids_are_refused() -> None:
    other = make_map([[S, S], [S, B]])
    with pytest.raises(XfaceValueError, match="share their grid"):
        map_difference(A, other)


def test_picture_returns_the_counts_it_draws(tmp_path: Path) -> None:
    diff = save_comparison(A, B_MAP, tmp_path / "cmp.svg")
    assert (tmp_path / "cmp.svg").read_bytes().lstrip().startswith(b"<?xml")
    assert diff.count(SeatedIn.ONLY_A) == 2


# --- designs of different widths: compared in units of D ---------------------------------------


def test_maps_of_different_widths_are_compared_at_the_same_x0_over_d() -> None:
    # A file's 0.05-wide face against a built-in face at width 1: the same x0 / D grid.
    grid = [[S, S, B], [S, B, B], [B, S, S]]
    narrow, wide = make_map(grid, width=0.05), make_map([[S, B, S], [P, B, B], [B, S, B]])
    diff = map_difference(narrow, wide)
    assert diff.M_a == 5
    assert diff.M_b == 3
    assert diff.count(SeatedIn.BOTH) == 2  # (0, 0) and (2, 1)


@settings(max_examples=40, deadline=None)
@given(
    width=st.floats(1e-3, 1e3, allow_nan=False),
    cells=st.lists(st.sampled_from([S, B, P]), min_size=9, max_size=9),
)
def test_a_maps_width_never_changes_its_comparison(width: float, cells: list[int]) -> None:
    # The engine runs in D: a design and its copy at another width compare as identical.
    grid = np.asarray(cells, dtype=np.int64).reshape(3, 3)
    diff = map_difference(make_map(grid), make_map(grid, width=width))
    assert diff.same_outcome == 9
    assert diff.count(SeatedIn.ONLY_A) == diff.count(SeatedIn.ONLY_B) == 0


def test_maps_on_different_x0_over_d_nodes_are_still_refused() -> None:
    a = make_map([[S, B, S], [P, B, B], [B, S, B]])
    b = make_map([[S, B, S], [P, B, B], [B, S, B]])
    b.x0 = b.x0 * 0.5  # width 1, but nodes from -D/2 to D/2
    with pytest.raises(XfaceValueError, match="share their grid"):
        map_difference(a, b)


# --- the comparison picture's layout ------------------------------------------------------------


def _drawn_figure(monkeypatch: pytest.MonkeyPatch, tmp_path: Path, grid: int) -> Figure:
    """The figure save_comparison writes for two ``grid`` x ``grid`` maps, drawn."""
    figures: list[Figure] = []
    real_save = comparefig.save

    def keep(fig: Figure, path: str | Path, fmt: object = None) -> Path:
        figures.append(fig)
        return real_save(fig, path, fmt)  # type: ignore[arg-type]

    monkeypatch.setattr(comparefig, "save", keep)
    rng = np.random.default_rng(grid)
    maps = [make_map(rng.choice([S, B, P], size=(grid, grid))) for _ in range(2)]
    save_comparison(maps[0], maps[1], tmp_path / "cmp.png", labels=("a design", "b design"))
    (fig,) = figures
    fig.canvas.draw()  # type: ignore[no-untyped-call]
    return fig


@pytest.mark.parametrize("grid", [11, 21, 41])
def test_compare_picture_labels_do_not_overlap_its_legends(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, grid: int
) -> None:
    fig = _drawn_figure(monkeypatch, tmp_path, grid)
    renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
    legends = [a for a in fig.findobj(Legend) if a.get_visible()]
    assert len(legends) == 3
    legend_boxes = [legend.get_window_extent(renderer) for legend in legends]
    in_legends = {id(t) for legend in legends for t in legend.findobj(Text)}
    labels = [
        t for t in fig.findobj(Text) if t.get_visible() and t.get_text() and id(t) not in in_legends
    ]
    assert any("initial angle" in t.get_text() for t in labels)  # the axis labels are here
    for text in labels:
        box = text.get_window_extent(renderer)
        for legend_box in legend_boxes:
            assert not box.overlaps(legend_box), (grid, text.get_text())
    for i, one in enumerate(legend_boxes):
        assert not any(one.overlaps(other) for other in legend_boxes[i + 1 :])


def _drawn_texts(fig: Figure) -> list[Text]:
    """The visible texts matplotlib draws: tick labels only of ticks inside their axis's view
    (the others exist, unseen)."""
    hidden = set()
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            lo, hi = sorted(axis.get_view_interval())
            for tick in [*axis.get_major_ticks(), *axis.get_minor_ticks()]:
                if not lo - 1e-9 <= tick.get_loc() <= hi + 1e-9:
                    hidden |= {id(tick.label1), id(tick.label2)}
    return [t for t in fig.findobj(Text) if t.get_visible() and id(t) not in hidden]


@pytest.mark.parametrize("grid", [11, 21, 41])
def test_compare_picture_texts_do_not_overlap_each_other(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, grid: int
) -> None:
    # Titles, axis labels, tick labels and legend entries: no two meet.
    fig = _drawn_figure(monkeypatch, tmp_path, grid)
    renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
    texts = [t for t in _drawn_texts(fig) if t.get_text().strip()]
    boxes = [(t.get_text(), t.get_window_extent(renderer)) for t in texts]
    for i, (text, box) in enumerate(boxes):
        for other, other_box in boxes[i + 1 :]:
            assert not box.overlaps(other_box), (grid, text, other)
