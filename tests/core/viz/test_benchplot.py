"""The work-precision plot: log-log axes, read back from a bench's CSV."""

from __future__ import annotations

from pathlib import Path

import pytest

from xface_core.errors import XfaceValueError
from xface_core.viz.benchplot import (
    plot_work_precision,
    read_work_precision_csv,
    work_precision_figure,
)

HEADER = "rtol,symmetry,default,ms_per_map,max_state_err_rad,p99_state_err_rad,mismatch_other\n"
LINES = [
    "0.001,True,False,150.0,6e-05,2e-08,3\n",
    "1e-08,True,True,170.0,6e-05,3e-08,0\n",
    "1e-08,False,True,290.0,6e-05,3e-08,0\n",
]


@pytest.fixture
def csv_path(tmp_path: Path) -> Path:
    path = tmp_path / "work_precision.csv"
    path.write_text(HEADER + "".join(LINES))
    return path


def test_csv_rows_are_typed(csv_path: Path) -> None:
    rows = read_work_precision_csv(csv_path)
    assert rows[0] == {
        "rtol": 0.001,
        "symmetry": True,
        "default": False,
        "ms_per_map": 150.0,
        "max_state_err_rad": 6e-05,
        "p99_state_err_rad": 2e-08,
        "mismatch_other": 3,
    }


def test_a_csv_without_a_column_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "bad.csv"
    path.write_text("rtol,symmetry\n0.1,True\n")
    with pytest.raises(XfaceValueError, match="line 2"):
        read_work_precision_csv(path)


def test_both_axes_are_logarithmic(csv_path: Path) -> None:
    ax = work_precision_figure(read_work_precision_csv(csv_path)).axes[0]
    assert (ax.get_xscale(), ax.get_yscale()) == ("log", "log")


def test_the_y_axis_is_labelled_on_the_axis(csv_path: Path) -> None:
    ax = work_precision_figure(read_work_precision_csv(csv_path)).axes[0]
    assert "error" in ax.get_ylabel()


def test_a_mismatch_count_is_written_by_its_points(csv_path: Path) -> None:
    ax = work_precision_figure(read_work_precision_csv(csv_path)).axes[0]
    assert [t.get_text() for t in ax.texts] == ["3", "3"]  # max and 99th percentile


def test_the_png_is_written(tmp_path: Path, csv_path: Path) -> None:
    plot_work_precision(read_work_precision_csv(csv_path), tmp_path)
    assert (tmp_path / "work_precision.png").read_bytes()[:4] == b"\x89PNG"


def test_rows_without_the_symmetry_skip_alone_are_refused() -> None:
    rows = [{"symmetry": False}]
    with pytest.raises(XfaceValueError, match="symmetry"):
        work_precision_figure(rows)
