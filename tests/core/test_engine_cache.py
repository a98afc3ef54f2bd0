"""The engine's numba cache is dropped when any engine source changes (numba itself only
checks the file of the cached function, not of the functions it calls)."""

from __future__ import annotations

from pathlib import Path

import pytest

from xface_core._engine import _stale


def _fill(directory: Path) -> list[Path]:
    files = [directory / "motion.velocity-1.py311.nbi", directory / "motion.velocity-1.py311.1.nbc"]
    for f in files:
        f.write_bytes(b"compiled")
    return files


def test_a_cache_without_stamp_is_dropped_and_stamped(tmp_path: Path) -> None:
    files = _fill(tmp_path)
    assert _stale.drop_stale_cache(tmp_path)
    assert not any(f.exists() for f in files)
    assert (tmp_path / _stale.STAMP_NAME).read_text() == _stale.source_digest()


def test_a_cache_of_the_current_sources_is_kept(tmp_path: Path) -> None:
    (tmp_path / _stale.STAMP_NAME).write_text(_stale.source_digest())
    files = _fill(tmp_path)
    assert not _stale.drop_stale_cache(tmp_path)
    assert all(f.exists() for f in files)


def test_a_cache_of_other_sources_is_dropped(tmp_path: Path) -> None:
    (tmp_path / _stale.STAMP_NAME).write_text("0" * 64)
    files = _fill(tmp_path)
    assert _stale.drop_stale_cache(tmp_path)
    assert not any(f.exists() for f in files)


def test_other_files_beside_the_cache_are_left_alone(tmp_path: Path) -> None:
    other = tmp_path / "module.cpython-311.pyc"
    other.write_bytes(b"bytecode")
    _stale.drop_stale_cache(tmp_path)
    assert other.exists()


def test_no_cache_location_is_not_an_error() -> None:
    assert not _stale.drop_stale_cache(None)


def test_the_sources_are_every_engine_module_and_the_codes() -> None:
    engine = Path(_stale.__file__).resolve().parent
    sources = set(_stale.engine_sources())
    assert set(engine.glob("*.py")) <= sources
    assert engine.parent / "codes.py" in sources


def test_the_digest_changes_with_any_source(tmp_path: Path) -> None:
    files = [tmp_path / "a.py", tmp_path / "b.py"]
    for f in files:
        f.write_text("x = 1\n")
    before = _stale.source_digest(files)
    files[1].write_text("x = 2\n")
    assert _stale.source_digest(files) != before


@pytest.mark.parametrize("ready", [True, False])
def test_engine_is_cached_says_whether_the_engine_state_is_ready(
    ready: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    from xface_core import runner

    state = runner.EngineState(ready, "cached" if ready else "compiles", 0.0 if ready else 60.0)
    monkeypatch.setattr(runner, "engine_state", lambda: state)
    assert runner.engine_is_cached() is ready


def test_the_cache_after_a_simulation_is_cached() -> None:
    import xface_core as xf
    from xface_core import runner

    xf.predict(xf.x_face(0.25, 1.0), 0.1, 0.1, margins=False)
    assert runner.engine_is_cached()
