"""The atlas cache against broken and hostile files, and against two writers at once.

Every bad file is ignored, rebuilt and replaced with one AtlasCacheWarning that names it and
says why; build_atlas never raises for the cache and always returns the atlas a fresh build
gives.
"""

from __future__ import annotations

import math
import os
import re
import subprocess
import sys
import tempfile
import time
import warnings
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import xface_core as xf
from xface_core.atlas.build import AcceptanceAtlas, AtlasCacheWarning, build_atlas
from xface_core.codes import Outcome

#: A tiny atlas (49 x 33 nodes, a few hundredths of a second to build).
TINY: dict[str, Any] = {"lateral_step": 1 / 8, "angle_step": 0.1, "angle_range": math.pi / 2}
DESIGN = xf.v_face(0.5, 1.0)
REPO = Path(xf.__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def fresh() -> AcceptanceAtlas:
    """The atlas as a build without a cache gives it."""
    return build_atlas(DESIGN, **TINY)


def cached_file(cache_dir: Path) -> Path:
    """Build the tiny atlas into ``cache_dir``; its file."""
    atlas = build_atlas(DESIGN, cache_dir=cache_dir, **TINY)
    path = cache_dir / f"atlas-{atlas.key}.npz"
    assert path.is_file()
    return path


def build_recording(cache_dir: Path) -> tuple[AcceptanceAtlas, list[warnings.WarningMessage]]:
    """build_atlas from ``cache_dir`` and every warning it gave (none filtered out)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        atlas = build_atlas(DESIGN, cache_dir=cache_dir, **TINY)
    return atlas, caught


def assert_loads_silently(cache_dir: Path, fresh: AcceptanceAtlas) -> None:
    """The file in ``cache_dir`` is a valid one now: read, not built, and no warning."""
    atlas, caught = build_recording(cache_dir)
    assert [str(w.message) for w in caught] == []
    assert atlas.build_seconds == 0.0
    assert np.array_equal(atlas.outcomes, fresh.outcomes)


def assert_rebuilt_with_one_warning(
    path: Path, fresh: AcceptanceAtlas, reason: str
) -> AcceptanceAtlas:
    """The bad file at ``path`` is not used: one AtlasCacheWarning naming the file and
    matching ``reason``, the atlas built afresh, the file replaced by a valid one."""
    atlas, caught = build_recording(path.parent)
    assert np.array_equal(atlas.outcomes, fresh.outcomes)
    assert atlas.build_seconds > 0.0
    assert len(caught) == 1, [str(w.message) for w in caught]
    assert issubclass(caught[0].category, AtlasCacheWarning)
    message = str(caught[0].message)
    assert str(path) in message
    assert re.search(reason, message), message
    assert_loads_silently(path.parent, fresh)
    return atlas


def stored_arrays(path: Path) -> dict[str, np.ndarray]:
    with np.load(path, allow_pickle=False) as data:
        return dict(data)


def rewrite(path: Path, **changes: np.ndarray | None) -> None:
    """Write the file at ``path`` again with arrays replaced (None: removed); the stored
    checksum is kept as it was."""
    arrays = stored_arrays(path)
    for name, value in changes.items():
        if value is None:
            arrays.pop(name, None)
        else:
            arrays[name] = value
    np.savez_compressed(path, **arrays)


def test_an_empty_cache_file_is_rebuilt_with_one_warning(
    tmp_path: Path, fresh: AcceptanceAtlas
) -> None:
    path = cached_file(tmp_path)
    path.write_bytes(b"")
    assert_rebuilt_with_one_warning(path, fresh, "empty")


def test_a_truncated_cache_file_is_rebuilt_with_one_warning(
    tmp_path: Path, fresh: AcceptanceAtlas
) -> None:
    path = cached_file(tmp_path)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])  # a writer killed half way, without the rename
    assert_rebuilt_with_one_warning(path, fresh, "unreadable")


def test_corrupt_compressed_data_is_rebuilt_with_one_warning(
    tmp_path: Path, fresh: AcceptanceAtlas
) -> None:
    path = cached_file(tmp_path)
    with zipfile.ZipFile(path) as archive:
        info = archive.getinfo("outcomes.npy")
    data = bytearray(path.read_bytes())
    # The member's deflate stream starts after its 30-byte local header, name and extra field.
    name_len = int.from_bytes(data[info.header_offset + 26 : info.header_offset + 28], "little")
    extra_len = int.from_bytes(data[info.header_offset + 28 : info.header_offset + 30], "little")
    start = info.header_offset + 30 + name_len + extra_len
    data[start : start + info.compress_size] = b"\xff" * info.compress_size
    path.write_bytes(bytes(data))
    assert_rebuilt_with_one_warning(path, fresh, "unreadable.*(error|Error)")


def test_wrong_shaped_outcomes_under_the_right_key_are_rebuilt_with_one_warning(
    tmp_path: Path, fresh: AcceptanceAtlas
) -> None:
    path = cached_file(tmp_path)
    rewrite(path, outcomes=fresh.outcomes[:-1])  # one row short: an IndexError in a query
    atlas = assert_rebuilt_with_one_warning(path, fresh, r"outcomes is int8 \(48, 33\)")
    edge = ([2.99], [0.0])  # in the last row's cell: an IndexError with the short outcomes
    assert atlas.seated_in_cell(*edge).tolist() == fresh.seated_in_cell(*edge).tolist()


def test_altered_outcomes_fail_the_checksum_and_are_rebuilt(
    tmp_path: Path, fresh: AcceptanceAtlas
) -> None:
    path = cached_file(tmp_path)
    seated = np.argwhere(fresh.outcomes == Outcome.SEATED)
    assert seated.size > 0
    altered = fresh.outcomes.copy()
    altered[tuple(seated[0])] = Outcome.BAD_MATE  # a valid code, the wrong one
    rewrite(path, outcomes=altered)
    assert_rebuilt_with_one_warning(path, fresh, "checksum mismatch")


def test_a_foreign_npz_under_the_atlas_name_is_rebuilt_with_one_warning(
    tmp_path: Path, fresh: AcceptanceAtlas
) -> None:
    path = cached_file(tmp_path)
    np.savez(path, weights=np.arange(3.0))
    assert_rebuilt_with_one_warning(path, fresh, r"holds \['weights.npy'\]")


def test_outcome_values_that_are_no_outcome_code_are_rebuilt(
    tmp_path: Path, fresh: AcceptanceAtlas
) -> None:
    # Signed again, as a writer of a valid-looking file would: the codes' own check refuses it.
    from xface_core.atlas.cache import checksum

    path = cached_file(tmp_path)
    arrays = stored_arrays(path)
    arrays.pop("checksum", None)
    arrays["outcomes"] = np.full_like(fresh.outcomes, 99)
    rewrite(path, outcomes=arrays["outcomes"], checksum=np.array(checksum(arrays)))
    assert_rebuilt_with_one_warning(path, fresh, "not outcome codes")


def test_a_file_without_format_and_checksum_is_rebuilt(
    tmp_path: Path, fresh: AcceptanceAtlas
) -> None:
    # The layout of format 1 (before the checksum) under the current name is not trusted.
    path = cached_file(tmp_path)
    rewrite(path, checksum=None, format=None)
    assert_rebuilt_with_one_warning(path, fresh, "not the arrays of an atlas file")


def test_a_directory_in_place_of_the_cache_file_is_left_and_the_atlas_returned(
    tmp_path: Path, fresh: AcceptanceAtlas
) -> None:
    path = cached_file(tmp_path)
    path.unlink()
    path.mkdir()
    (path / "someone's.txt").write_text("kept")
    atlas, caught = build_recording(tmp_path)
    assert len(caught) == 1, [str(w.message) for w in caught]
    assert issubclass(caught[0].category, AtlasCacheWarning)
    assert str(path) in str(caught[0].message)
    assert "directory" in str(caught[0].message)
    assert np.array_equal(atlas.outcomes, fresh.outcomes)
    assert (path / "someone's.txt").read_text() == "kept"
    assert sorted(p.name for p in tmp_path.iterdir()) == [path.name]  # no temporary left


def test_a_cache_dir_that_is_a_file_is_a_warning_and_the_atlas_is_returned(
    tmp_path: Path, fresh: AcceptanceAtlas
) -> None:
    not_a_folder = tmp_path / "cache"
    not_a_folder.write_text("a file")
    atlas, caught = build_recording(not_a_folder)
    assert len(caught) == 1, [str(w.message) for w in caught]
    assert issubclass(caught[0].category, AtlasCacheWarning)
    assert "not written" in str(caught[0].message)
    assert str(not_a_folder) in str(caught[0].message)
    assert np.array_equal(atlas.outcomes, fresh.outcomes)
    assert not_a_folder.read_text() == "a file"


def test_cache_problems_go_to_the_given_reporter_instead_of_a_warning(
    tmp_path: Path, fresh: AcceptanceAtlas
) -> None:
    # A node logs them with its own logger (a Python warning is process-wide).
    path = cached_file(tmp_path)
    path.write_bytes(b"")
    told: list[str] = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        atlas = build_atlas(DESIGN, cache_dir=tmp_path, on_cache_problem=told.append, **TINY)
    assert np.array_equal(atlas.outcomes, fresh.outcomes)
    assert [str(w.message) for w in caught] == []
    assert len(told) == 1
    assert str(path) in told[0]
    assert "empty" in told[0]


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into a read-only folder")
def test_a_read_only_cache_dir_is_a_warning_and_the_atlas_is_returned(
    tmp_path: Path, fresh: AcceptanceAtlas
) -> None:
    folder = tmp_path / "cache"
    folder.mkdir(mode=0o500)
    try:
        atlas, caught = build_recording(folder)
    finally:
        folder.chmod(0o700)
    assert len(caught) == 1, [str(w.message) for w in caught]
    assert issubclass(caught[0].category, AtlasCacheWarning)
    assert "not written" in str(caught[0].message)
    assert np.array_equal(atlas.outcomes, fresh.outcomes)
    assert list(folder.iterdir()) == []


def test_a_failed_write_leaves_no_temporary_file_and_keeps_the_old_one(
    tmp_path: Path, fresh: AcceptanceAtlas, monkeypatch: pytest.MonkeyPatch
) -> None:
    # A folder that takes the temporary file but not the rename (read-only for root too).
    path = cached_file(tmp_path)
    before = path.read_bytes()

    def refuse(*args: Any, **kwargs: Any) -> None:
        raise PermissionError("read-only file system")

    with monkeypatch.context() as patch:
        patch.setattr(os, "replace", refuse)
        with pytest.raises(PermissionError):
            fresh.save(path)
    assert sorted(p.name for p in tmp_path.iterdir()) == [path.name]
    assert path.read_bytes() == before


#: One of two processes saving and reading the same atlas in the same folder: exits 1 on any
#: error or warning (a rebuild means a reader saw a broken file).
_WRITER = """
import sys, time, warnings
from pathlib import Path
import xface_core as xf
from xface_core.atlas.build import build_atlas
warnings.simplefilter("error")
folder, me, rounds = Path(sys.argv[1]), sys.argv[2], int(sys.argv[3])
grid = dict(lateral_step=1 / 8, angle_step=0.1, angle_range=%r)
atlas = build_atlas(xf.v_face(0.5, 1.0), cache_dir=folder, **grid)
assert atlas.build_seconds == 0.0
path = folder / f"atlas-{atlas.key}.npz"
(folder / f"ready-{me}").touch()
deadline = time.monotonic() + 120.0
while not (folder / "go").exists():  # start together, so the saves overlap
    assert time.monotonic() < deadline, "never told to go"
    time.sleep(0.005)
for _ in range(rounds):
    atlas.save(path)
    again = build_atlas(xf.v_face(0.5, 1.0), cache_dir=folder, **grid)
    assert again.build_seconds == 0.0
""" % (math.pi / 2)


def test_two_processes_saving_the_same_atlas_at_once_never_fail(
    tmp_path: Path, fresh: AcceptanceAtlas
) -> None:
    path = cached_file(tmp_path)
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]),
    }
    writers = [
        subprocess.Popen(
            [sys.executable, "-c", _WRITER, str(tmp_path), str(i), "150"],
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        for i in range(2)
    ]
    try:
        deadline = time.monotonic() + 120.0
        while not all((tmp_path / f"ready-{i}").exists() for i in range(2)):
            assert all(w.poll() is None for w in writers), "a writer died before starting"
            assert time.monotonic() < deadline
            time.sleep(0.01)
        (tmp_path / "go").touch()
        results = [w.communicate(timeout=300) for w in writers]
    finally:
        for w in writers:
            if w.poll() is None:
                w.kill()
                w.wait()
    assert [w.returncode for w in writers] == [0, 0], [err for _, err in results]
    assert sorted(p.name for p in tmp_path.glob("*.npz*")) == [path.name]  # no temporaries
    assert_loads_silently(tmp_path, fresh)


@pytest.fixture(scope="module")
def valid_file_bytes(tmp_path_factory: pytest.TempPathFactory) -> tuple[str, bytes]:
    """The tiny atlas's cache file: its name and bytes."""
    path = cached_file(tmp_path_factory.mktemp("valid"))
    return path.name, path.read_bytes()


@st.composite
def damaged(draw: st.DrawFn, valid: bytes) -> bytes:
    """A valid cache file truncated, with bytes flipped, or with one array replaced."""
    how = draw(st.sampled_from(["truncate", "flip", "replace"]))
    if how == "truncate":
        return valid[: draw(st.integers(0, len(valid) - 1))]
    if how == "flip":
        data = bytearray(valid)
        for at in draw(st.lists(st.integers(0, len(valid) - 1), min_size=1, max_size=8)):
            data[at] ^= draw(st.integers(1, 255))
        return bytes(data)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "f.npz"
        path.write_bytes(valid)
        arrays = stored_arrays(path)
        name = draw(st.sampled_from(sorted(arrays)))
        dtype = draw(st.sampled_from(["int8", "bool", "float64", "int64", "<U24"]))
        shape = draw(hnp.array_shapes(min_dims=0, max_dims=3, max_side=50))
        arrays[name] = draw(hnp.arrays(dtype, shape))
        np.savez_compressed(path, **arrays)
        return path.read_bytes()


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_any_damaged_cache_file_gives_the_fresh_atlas_and_never_raises(
    data: st.DataObject, valid_file_bytes: tuple[str, bytes], fresh: AcceptanceAtlas
) -> None:
    name, valid = valid_file_bytes
    bad = data.draw(damaged(valid))
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / name
        path.write_bytes(bad)
        atlas, caught = build_recording(path.parent)
        assert np.array_equal(atlas.outcomes, fresh.outcomes)
        assert len(caught) <= 1
        assert all(issubclass(w.category, AtlasCacheWarning) for w in caught)
        # Used without a word only if it was still a valid file (a flip in a zip field that
        # nothing reads); otherwise rebuilt, and the file replaced.
        assert (atlas.build_seconds == 0.0) == (not caught)
        assert_loads_silently(path.parent, fresh)
