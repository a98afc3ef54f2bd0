"""Design studies: one row per design, resumable, the same table whatever the executor."""

from __future__ import annotations

import multiprocessing
import os
import signal
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow.parquet as pq
import pytest

import xface_core as xf
from xface_core.study.executors import LocalPool
from xface_core.study.noise import PoseNoise
from xface_core.study.run import StudyProgress, read_study, run_study
from xface_core.study.space import DesignPoint, DesignSpace
from xface_core.study.table import KEY_COLUMNS

SPACE = DesignSpace(faces=("X", "S"), h_over_d=(0.25, 1.0), r_p=(0.0, 1.0, 2.0))
GRID = 9


@pytest.fixture(scope="module")
def serial(tmp_path_factory: pytest.TempPathFactory) -> Any:
    out = tmp_path_factory.mktemp("serial") / "study.parquet"
    run_study(SPACE, out, grid=GRID, workers=1)
    return read_study(out, timing=False)


def test_a_row_holds_what_the_design_s_map_says(serial: Any) -> None:
    row = next(
        r for r in serial.to_pylist() if (r["face"], r["h_over_d"], r["r_p"]) == ("X", 1.0, 2.0)
    )
    amap = xf.acceptance_map(xf.x_face(1.0, 2.0), grid=GRID)
    assert row["M"] == amap.M
    assert (
        row["n_seated"] + row["n_bad_mate"] + row["n_out_of_reach"]
        == amap.counts()[xf.Outcome.SEATED]
        + amap.counts()[xf.Outcome.BAD_MATE]
        + amap.counts()[xf.Outcome.OUT_OF_REACH]
    )
    rows, cols = amap.guaranteed
    assert row["guaranteed_cells"] == len(rows) * len(cols)
    assert row["guaranteed_x0_min"] == amap.x0[rows.start]
    assert row["guaranteed_theta0_max"] == amap.theta0[cols.stop - 1]


def test_every_outcome_is_counted_once(serial: Any) -> None:
    counts = sum(np.array(serial[f"n_{o.name.lower()}"].to_pylist()) for o in xf.Outcome)
    assert (counts == GRID * GRID).all()


def test_the_table_has_one_sorted_row_per_design(serial: Any) -> None:
    keys = list(zip(*(serial[c].to_pylist() for c in KEY_COLUMNS), strict=True))
    assert keys == sorted(DesignPoint(*k) for k in keys)
    assert len(set(keys)) == len(SPACE) == serial.num_rows


def test_local_processes_give_the_serial_table_bit_for_bit(serial: Any, tmp_path: Path) -> None:
    run_study(SPACE, tmp_path / "s.parquet", grid=GRID, workers=2)
    assert read_study(tmp_path / "s.parquet", timing=False).equals(serial)


def test_any_executor_gives_the_serial_table_bit_for_bit(serial: Any, tmp_path: Path) -> None:
    with ThreadPoolExecutor(3) as pool:
        run_study(SPACE, tmp_path / "s.parquet", grid=GRID, executor=pool)
    assert read_study(tmp_path / "s.parquet", timing=False).equals(serial)


def test_the_time_column_is_kept_apart_from_the_results(serial: Any, tmp_path: Path) -> None:
    run_study(SPACE, tmp_path / "s.parquet", grid=GRID, workers=1)
    timed = read_study(tmp_path / "s.parquet")
    assert "seconds" in timed.column_names
    assert "seconds" not in serial.column_names
    assert all(s > 0 for s in timed["seconds"].to_pylist())


def test_a_rerun_skips_the_designs_already_there(tmp_path: Path) -> None:
    small = DesignSpace(faces=("X",), h_over_d=(0.25,), r_p=(0.0, 1.0))
    larger = DesignSpace(faces=("X",), h_over_d=(0.25,), r_p=(0.0, 1.0, 2.0))
    first = run_study(small, tmp_path / "s.parquet", grid=5, workers=1)
    second = run_study(larger, tmp_path / "s.parquet", grid=5, workers=1)
    assert (first.computed, second.computed, second.skipped) == (2, 1, 2)
    assert read_study(tmp_path / "s.parquet").num_rows == 3


def test_a_finished_study_is_one_parquet_file(tmp_path: Path) -> None:
    run_study(SPACE, tmp_path / "s.parquet", grid=5, workers=1)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.parquet"]
    assert pq.read_table(tmp_path / "s.parquet").num_rows == len(SPACE)


def test_rows_are_on_disk_as_each_design_finishes(tmp_path: Path) -> None:
    out = tmp_path / "s.parquet"
    seen: list[int] = []

    def look(p: StudyProgress) -> None:
        if p.done:
            seen.append(read_study(out).num_rows)

    run_study(SPACE, out, grid=5, workers=1, progress=look)
    assert seen == list(range(1, len(SPACE) + 1))


@pytest.mark.parametrize(
    ("change", "message"),
    [({"grid": 7}, "grid 5 there, 7 here"), ({"theta_kind": "paper"}, "theta_grid")],
)
def test_an_output_of_another_study_is_refused(
    tmp_path: Path, change: dict[str, Any], message: str
) -> None:
    space = DesignSpace(faces=("V",), h_over_d=(0.5,), r_p=(1.0,))
    run_study(space, tmp_path / "s.parquet", grid=5, workers=1)
    kwargs: dict[str, Any] = {"grid": 5, **change}
    with pytest.raises(xf.XfaceValueError, match=message):
        run_study(space, tmp_path / "s.parquet", workers=1, **kwargs)


def test_other_solver_settings_are_another_study(tmp_path: Path) -> None:
    space = DesignSpace(faces=("V",), h_over_d=(0.5,), r_p=(1.0,))
    run_study(space, tmp_path / "s.parquet", grid=5, workers=1)
    tight = xf.SolverSettings(rtol=1e-10)
    with pytest.raises(xf.XfaceValueError, match="settings"):
        run_study(space, tmp_path / "s.parquet", grid=5, workers=1, settings=tight)


def test_a_parquet_file_that_is_no_study_is_refused(tmp_path: Path) -> None:
    import pyarrow as pa

    pq.write_table(pa.table({"a": [1]}), tmp_path / "other.parquet")
    with pytest.raises(xf.XfaceValueError, match="not an xface study"):
        run_study(SPACE, tmp_path / "other.parquet", grid=5, workers=1)


def test_a_worker_that_dies_has_its_designs_retried(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    restarts: list[int] = []
    restart = LocalPool.restart

    def counted(pool: LocalPool) -> None:
        restarts.append(1)
        restart(pool)

    monkeypatch.setattr(LocalPool, "restart", counted)
    killed: list[int] = []

    def kill_a_worker(p: StudyProgress) -> None:
        workers = multiprocessing.active_children()
        if p.done == 1 and workers and not killed:
            killed.append(workers[0].pid or 0)
            os.kill(killed[0], signal.SIGKILL)  # a worker of this test's own pool

    # Designs big enough (21 x 21 poses) that most are still to do when the worker dies.
    run = run_study(SPACE, tmp_path / "s.parquet", grid=21, workers=2, progress=kill_a_worker)
    run_study(SPACE, tmp_path / "serial.parquet", grid=21, workers=1)
    assert killed
    assert restarts == [1]
    assert run.computed == len(SPACE)
    expected = read_study(tmp_path / "serial.parquet", timing=False)
    assert read_study(tmp_path / "s.parquet", timing=False).equals(expected)


def _hand_drawn_v(h_over_d: float, r_p: float) -> xf.FaceDesign:
    """The V-Face drawn by hand with custom_face: a male triangle of height H on the base's
    line r_p above the pivot, the matching notch on the moving part."""
    base = [(-0.5, -1.0), (0.5, -1.0), (0.5, r_p), (0.0, r_p + h_over_d), (-0.5, r_p)]
    moving = [(-0.5, -1.0), (0.5, -1.0), (0.5, r_p + h_over_d), (0.0, r_p), (-0.5, r_p + h_over_d)]
    return xf.custom_face([base], [moving], mated_distance=2 * r_p + h_over_d)


def test_a_custom_family_sweeps_like_a_built_in_face(tmp_path: Path) -> None:
    space = DesignSpace(
        faces=("V", "hand-drawn V"),
        h_over_d=(0.5,),
        r_p=(1.0, 2.0),
        families={"hand-drawn V": _hand_drawn_v},
    )
    run_study(space, tmp_path / "s.parquet", grid=7, workers=1)
    rows = read_study(tmp_path / "s.parquet", timing=False).to_pylist()
    by_face: dict[str, list[int]] = {}
    for r in rows:
        by_face.setdefault(r["face"], []).append(r["M"])
    assert by_face["hand-drawn V"] == by_face["V"]


def test_a_family_may_be_a_lambda_even_with_worker_processes(tmp_path: Path) -> None:
    # Families are called in the calling process; only the designs go to the workers.
    space = DesignSpace(
        faces=("lambda V",),
        h_over_d=(0.5,),
        r_p=(1.0, 2.0),
        families={"lambda V": lambda h, rp: _hand_drawn_v(h, rp)},
    )
    run = run_study(space, tmp_path / "s.parquet", grid=7, workers=2)
    assert run.computed == 2


def test_a_family_that_builds_no_design_is_refused_before_running(tmp_path: Path) -> None:
    space = DesignSpace(faces=("bad",), h_over_d=(0.5,), r_p=(1.0,), families={"bad": max})  # type: ignore[dict-item]
    with pytest.raises(xf.XfaceValueError, match="must return a FaceDesign"):
        run_study(space, tmp_path / "s.parquet", grid=5, workers=1)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("space", "message"),
    [
        (DesignSpace(faces=(), h_over_d=(1.0,), r_p=(1.0,)), "empty"),
        (DesignSpace(faces=("X",), h_over_d=(1.0, 1.0), r_p=(1.0,)), "twice"),
        (DesignSpace(faces=("X",), h_over_d=(-1.0,), r_p=(1.0,)), "h_over_d"),
        (DesignSpace(faces=("X",), h_over_d=(1.0,), r_p=(1.0,), friction=(-0.1,)), "friction"),
        (DesignSpace(faces=("X",), h_over_d=tuple(range(1, 1001)), r_p=tuple(range(101))), "split"),
    ],
)
def test_a_bad_design_space_is_refused(space: DesignSpace, message: str, tmp_path: Path) -> None:
    with pytest.raises(xf.XfaceValueError, match=message):
        run_study(space, tmp_path / "s.parquet", grid=5, workers=1)


@pytest.mark.parametrize(("grid", "workers"), [(4, 1), (1003, 1), (5, 0)])
def test_absurd_sizes_are_refused(grid: int, workers: int, tmp_path: Path) -> None:
    with pytest.raises(xf.XfaceValueError):
        run_study(SPACE, tmp_path / "s.parquet", grid=grid, workers=workers)


def test_parts_are_folded_into_the_table_while_a_study_runs(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr("xface_core.study.table.FOLD_EVERY", 4)
    out = tmp_path / "s.parquet"
    parts = tmp_path / "s.parquet.parts"
    seen: list[tuple[int, int]] = []

    def look(p: StudyProgress) -> None:
        if p.done:
            seen.append((len(list(parts.glob("*.parquet"))), read_study(out).num_rows))

    run_study(SPACE, out, grid=5, workers=1, progress=look)
    assert max(n for n, _ in seen) == 3  # never more than FOLD_EVERY - 1 parts
    assert [rows for _, rows in seen] == list(range(1, len(SPACE) + 1))  # nothing lost


def test_with_pose_noise_local_processes_give_the_serial_table(tmp_path: Path) -> None:
    noise = PoseNoise(0.05, 0.05, samples=4)
    run_study(SPACE, tmp_path / "a.parquet", grid=5, noise=noise, workers=1)
    run_study(SPACE, tmp_path / "b.parquet", grid=5, noise=noise, workers=2)
    a = read_study(tmp_path / "a.parquet", timing=False)
    assert all(p is not None for p in a["seat_probability"].to_pylist())
    assert read_study(tmp_path / "b.parquet", timing=False).equals(a)


def test_without_pose_noise_the_seat_probability_is_null(serial: Any) -> None:
    assert serial["seat_probability"].null_count == serial.num_rows


def test_another_pose_noise_is_another_study(tmp_path: Path) -> None:
    space = DesignSpace(faces=("V",), h_over_d=(0.5,), r_p=(1.0,))
    run_study(space, tmp_path / "s.parquet", grid=5, workers=1, noise=PoseNoise(0.05, 0.05))
    with pytest.raises(xf.XfaceValueError, match="pose_noise"):
        run_study(space, tmp_path / "s.parquet", grid=5, workers=1, noise=PoseNoise(0.1, 0.05))


def test_files_left_half_written_by_a_killed_run_are_removed(tmp_path: Path) -> None:
    space = DesignSpace(faces=("V",), h_over_d=(0.5,), r_p=(1.0,))
    (tmp_path / "s.parquet.parts").mkdir()
    (tmp_path / "s.parquet.parts" / "abc.tmp").write_bytes(b"PAR1 half")
    (tmp_path / "s.parquet.tmp").write_bytes(b"PAR1 half")
    run_study(space, tmp_path / "s.parquet", grid=5, workers=1)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.parquet"]
