"""store: engine maps kept as plain arrays, read back the same, hostile files refused."""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import xface_core as xf
from xface_core.crosscheck import DEFAULT_ENGINE, EngineRun
from xface_core.crosscheck.compare import EngineMap, engine_map
from xface_core.crosscheck.store import MAX_BYTES, MAX_CELLS, StoredEvidence, load, save
from xface_core.errors import XfaceValueError


@pytest.fixture(scope="module")
def small_map() -> EngineMap:
    """Three real engine cells of X 0.25/2: a seat, a jam and one out of reach (NaN height)."""
    cells = [(0.0, 0.0), (0.95, 1.4), (5.0, 0.0)]
    return engine_map(xf.x_face(0.25, 2.0), cells=cells, workers=1)


def _probe() -> tuple[tuple[float, float], EngineRun]:
    run = EngineRun(xf.Outcome.SEATED, "seated", 0.1, 0.1, 1.0, 0.0, 2.0, 1.0, 40, False)
    return (0.302, 0.2), run


def test_a_map_reads_back_field_for_field(
    tmp_path: Path, small_map: EngineMap, same_run: Callable[[EngineRun, EngineRun], bool]
) -> None:
    cell, run = _probe()
    path = tmp_path / "m.npz"
    save(path, StoredEvidence("k1", "X 0.25, 2", small_map, {cell: run}))
    back = load(path)
    assert (back.key, back.label) == ("k1", "X 0.25, 2")
    e = back.engine
    assert np.array_equal(e.x0, small_map.x0)
    assert np.array_equal(e.theta0, small_map.theta0)
    assert np.array_equal(e.changed, small_map.changed)
    for side in ("sharp", "rounded"):
        pairs = zip(getattr(e, side), getattr(small_map, side), strict=True)
        assert all(same_run(a, b) for a, b in pairs)
    assert e.settings == small_map.settings
    assert (e.grid, e.rounding, e.converged) == (small_map.grid, small_map.rounding, None)
    assert (e.step_history, e.stall_changes, e.converge_by) == (
        small_map.step_history,
        small_map.stall_changes,
        small_map.converge_by,
    )
    assert list(back.probes) == [cell]
    assert same_run(back.probes[cell], run)


def test_an_out_of_reach_run_keeps_its_nan_height(tmp_path: Path, small_map: EngineMap) -> None:
    path = tmp_path / "m.npz"
    save(path, StoredEvidence("k", "", small_map))
    last = load(path).engine.sharp[-1]
    assert last.outcome is xf.Outcome.OUT_OF_REACH
    assert math.isnan(last.y_m)


def test_a_file_with_a_pickle_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "evil.npz"
    np.savez(path, meta=np.array([{"format": "xface-engine-map"}], dtype=object))
    with pytest.raises(XfaceValueError, match=r"evil\.npz"):
        load(path)


def test_a_truncated_file_is_refused(tmp_path: Path, small_map: EngineMap) -> None:
    path = tmp_path / "m.npz"
    save(path, StoredEvidence("k", "", small_map))
    path.write_bytes(path.read_bytes()[:100])
    with pytest.raises(XfaceValueError, match="cannot be read"):
        load(path)


def test_another_format_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "other.npz"
    np.savez(path, meta=np.asarray(json.dumps({"format": "something else", "version": 1})))
    with pytest.raises(XfaceValueError, match="not an engine map"):
        load(path)


def _rewrite(path: Path, **changes: object) -> None:
    with np.load(path, allow_pickle=False) as npz:
        arrays = {name: npz[name] for name in npz.files}
    arrays.update({k: np.asarray(v) for k, v in changes.items()})
    np.savez(path, **arrays)  # type: ignore[arg-type]


def test_an_unknown_outcome_code_is_refused(tmp_path: Path, small_map: EngineMap) -> None:
    path = tmp_path / "m.npz"
    save(path, StoredEvidence("k", "", small_map))
    _rewrite(path, sharp_outcome=np.array([3, 4, 99], dtype=np.int8))
    with pytest.raises(XfaceValueError, match="unknown outcome codes"):
        load(path)


def test_a_column_of_the_wrong_length_is_refused(tmp_path: Path, small_map: EngineMap) -> None:
    path = tmp_path / "m.npz"
    save(path, StoredEvidence("k", "", small_map))
    _rewrite(path, rounded_phi_b=np.zeros(2))
    with pytest.raises(XfaceValueError, match="rounded_phi_b"):
        load(path)


def test_a_non_finite_setting_is_refused(tmp_path: Path, small_map: EngineMap) -> None:
    path = tmp_path / "m.npz"
    save(path, StoredEvidence("k", "", replace(small_map, settings=DEFAULT_ENGINE)))
    with np.load(path, allow_pickle=False) as npz:
        meta = json.loads(str(npz["meta"]))
    meta["settings"]["step"] = float("inf")
    _rewrite(path, meta=json.dumps(meta))
    with pytest.raises(XfaceValueError, match="not finite"):
        load(path)


def test_an_absurd_number_of_cells_is_refused(tmp_path: Path, small_map: EngineMap) -> None:
    path = tmp_path / "m.npz"
    save(path, StoredEvidence("k", "", small_map))
    _rewrite(path, probe_x0=np.zeros(MAX_CELLS + 1))
    with pytest.raises(XfaceValueError, match="at most"):
        load(path)


def test_a_file_whose_arrays_would_take_too_much_memory_is_refused_unread(tmp_path: Path) -> None:
    path = tmp_path / "bomb.npz"
    np.savez_compressed(path, x0=np.zeros(MAX_BYTES // 8 + 1))  # a few kB on disk
    assert path.stat().st_size < MAX_BYTES // 100
    with pytest.raises(XfaceValueError, match="bytes"):
        load(path)
