"""The study table on disk loses nothing and mixes nothing: every file is checked on reading
and on resuming (settings, checksum, versions), a damaged part is moved aside and its design
computed again, a row that contradicts another is reported, and no damaged file ends in a
raw pyarrow error or a silently wrong table."""

from __future__ import annotations

import json
import shutil
import tempfile
import warnings
from pathlib import Path
from typing import Any
from unittest import mock

import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from hypothesis import event, given, settings
from hypothesis import strategies as st

import xface_core as xf
from xface_core.errors import XfaceWarning
from xface_core.study.run import read_study, run_study
from xface_core.study.space import DesignSpace
from xface_core.study.table import StudyFile

#: Four designs on a 5 x 5 pose grid: the whole study takes milliseconds.
SPACE = DesignSpace(faces=("X", "V"), h_over_d=(0.25,), r_p=(1.0, 2.0))
FIRST_HALF = DesignSpace(faces=("X",), h_over_d=(0.25,), r_p=(1.0, 2.0))
GRID = 5


def _parts(out: Path) -> list[Path]:
    return sorted(out.with_name(out.name + ".parts").glob("*.parquet"))


def _interrupted_study(out: Path) -> None:
    """A study as a killed sweep leaves it: the X-Face's two designs folded into the table,
    the V-Face's two as parts (the run's fold never came)."""
    run_study(FIRST_HALF, out, grid=GRID, workers=1)
    with mock.patch.object(StudyFile, "compact", return_value=None):
        run_study(SPACE, out, grid=GRID, workers=1)
    assert len(_parts(out)) == 2


@pytest.fixture(scope="module")
def clean() -> Any:
    """The table of an uninterrupted run, without timing."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "clean.parquet"
        run_study(SPACE, out, grid=GRID, workers=1)
        return read_study(out, timing=False)


@pytest.fixture(scope="module")
def template(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An interrupted study to copy (the table and two parts)."""
    out = tmp_path_factory.mktemp("template") / "study.parquet"
    _interrupted_study(out)
    return out


@pytest.fixture(scope="module")
def foreign_part(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A part of another study (a 7 x 7 pose grid) of one of SPACE's designs."""
    out = tmp_path_factory.mktemp("foreign") / "study.parquet"
    with mock.patch.object(StudyFile, "compact", return_value=None):
        run_study(FIRST_HALF, out, grid=7, workers=1)
    return _parts(out)[0]


def _copy_study(template: Path, folder: Path) -> Path:
    out = folder / template.name
    shutil.copy(template, out)
    shutil.copytree(template.with_name(template.name + ".parts"), folder / (out.name + ".parts"))
    return out


@pytest.fixture
def study(template: Path, tmp_path: Path) -> Path:
    return _copy_study(template, tmp_path)


def _truncate(file: Path, keep: int) -> None:
    file.write_bytes(file.read_bytes()[:keep])


def test_a_foreign_part_is_refused_by_reading_and_by_resuming(
    study: Path, foreign_part: Path
) -> None:
    copied = study.with_name(study.name + ".parts") / "0-foreign.parquet"
    shutil.copy(foreign_part, copied)
    for attempt in (lambda: read_study(study), lambda: run_study(SPACE, study, grid=GRID)):
        with pytest.raises(xf.XfaceValueError, match="belongs to another study") as err:
            attempt()
        assert str(copied) in str(err.value)
        assert "grid 7 there, 5" in str(err.value)
    assert copied.exists()  # refused, not deleted


def _study_with_one_m_more(folder: Path) -> Path:
    """A study whose X-Face r_p=1 design has one SEATED pose more: the parts of a run whose
    engine said so, each whole and with its checksum (as another engine's would be)."""
    from xface_core.study import run as run_module

    real = run_module.evaluate_design

    def one_more(job: Any) -> dict[str, Any]:
        row = real(job)
        if (job.point.face, job.point.r_p) == ("X", 1.0):
            row["M"] += 1
        return row

    out = folder / "other.parquet"
    with (
        mock.patch.object(run_module, "evaluate_design", one_more),
        mock.patch.object(StudyFile, "compact", return_value=None),
    ):
        run_study(FIRST_HALF, out, grid=GRID, workers=1)
    return out


def test_a_row_that_differs_from_its_design_s_row_in_the_table_is_reported(
    study: Path, clean: Any, tmp_path_factory: pytest.TempPathFactory
) -> None:
    other = _study_with_one_m_more(tmp_path_factory.mktemp("other"))
    m_in_part = {}
    for part in _parts(other):
        row = pq.read_table(part).to_pylist()[0]
        if row["r_p"] == 1.0:
            m_in_part[part.name] = row["M"]
            shutil.copy(part, study.with_name(study.name + ".parts") / part.name)
    design = "face=X, h_over_d=0.25, r_p=1.0, friction=0.0, damping_ratio=1.0"
    with pytest.warns(XfaceWarning, match=design):
        assert read_study(study, timing=False).equals(clean)  # the table's row is kept
    with pytest.warns(XfaceWarning, match=f"{design}.*moved it to"):
        run_study(SPACE, study, grid=GRID, workers=1)
    assert read_study(study, timing=False).equals(clean)
    (moved,) = study.with_name(study.name + ".quarantine").iterdir()
    assert {moved.name: pq.read_table(moved)["M"][0].as_py()} == m_in_part  # not deleted


def test_a_part_whose_row_does_not_match_its_checksum_is_left_out(study: Path, clean: Any) -> None:
    part = next(p for p in _parts(study) if pq.read_table(p)["r_p"][0].as_py() == 1.0)
    table = pq.read_table(part)
    altered = table.set_column(
        table.schema.get_field_index("M"), "M", pa.array([table["M"][0].as_py() + 1])
    )
    pq.write_table(altered, part)  # the part's own metadata (and checksum), another M
    with pytest.warns(XfaceWarning, match=f"{part} is left out: .*checksum"):
        table = read_study(study, timing=False)
    assert table.num_rows == len(SPACE) - 1
    assert all(row in clean.to_pylist() for row in table.to_pylist())


def test_a_corrupt_part_is_left_out_of_reading_with_a_warning(study: Path, clean: Any) -> None:
    part = _parts(study)[0]
    _truncate(part, 100)
    with pytest.warns(XfaceWarning, match=f"{part} is left out: not a readable Parquet file"):
        table = read_study(study, timing=False)
    assert table.num_rows == len(SPACE) - 1
    assert all(row in clean.to_pylist() for row in table.to_pylist())


def test_a_corrupt_part_is_moved_aside_and_its_design_computed_again(
    study: Path, clean: Any
) -> None:
    part = _parts(study)[0]
    _truncate(part, 100)
    with pytest.warns(XfaceWarning, match=f"{part}: not a readable Parquet file.*moved it to"):
        run = run_study(SPACE, study, grid=GRID, workers=1)
    assert (run.computed, run.skipped) == (1, 3)
    assert read_study(study, timing=False).equals(clean)
    quarantine = study.with_name(study.name + ".quarantine")
    assert [p.name for p in quarantine.iterdir()] == [part.name]
    assert (quarantine / part.name).stat().st_size == 100  # kept as it was


def test_a_damaged_table_is_a_clear_error_and_is_left_in_place(study: Path) -> None:
    _truncate(study, 200)
    for attempt in (lambda: read_study(study), lambda: run_study(SPACE, study, grid=GRID)):
        with pytest.raises(xf.XfaceValueError, match=f"{study} is damaged: .*move it aside"):
            attempt()
    assert study.stat().st_size == 200


def test_the_table_records_the_xface_and_engine_versions(study: Path) -> None:
    from xface_core.runner import engine_digest

    run_study(SPACE, study, grid=GRID, workers=1)
    stored = json.loads(pq.read_schema(study).metadata[b"xface.writers"])
    assert stored == [{"xface": "0.1.0", "engine": engine_digest()}]
    assert json.loads(read_study(study).schema.metadata[b"xface.writers"]) == stored


def _as_other_version(engine: str = "0" * 64) -> Any:
    other = {"xface": "0.0.9", "engine": engine}
    return mock.patch("xface_core.study.table.writer_version", return_value=other)


def test_resuming_rows_of_another_engine_version_is_refused_naming_both(tmp_path: Path) -> None:
    from xface_core.runner import engine_digest

    out = tmp_path / "study.parquet"
    with _as_other_version():
        run_study(FIRST_HALF, out, grid=GRID, workers=1)
    with pytest.raises(xf.XfaceValueError, match="--allow-version-mix") as err:
        run_study(SPACE, out, grid=GRID, workers=1)
    assert "xface 0.0.9 (engine 000000000000)" in str(err.value)
    assert f"xface 0.1.0 (engine {engine_digest()[:12]})" in str(err.value)
    assert read_study(out).num_rows == len(FIRST_HALF)  # nothing written


def test_allowing_a_version_mix_resumes_and_records_both_versions(
    tmp_path: Path, clean: Any
) -> None:
    out = tmp_path / "study.parquet"
    with _as_other_version():
        run_study(FIRST_HALF, out, grid=GRID, workers=1)
    run = run_study(SPACE, out, grid=GRID, workers=1, allow_version_mix=True)
    assert (run.computed, run.skipped) == (2, 2)
    writers = json.loads(read_study(out).schema.metadata[b"xface.writers"])
    assert {w["xface"] for w in writers} == {"0.0.9", "0.1.0"}
    assert read_study(out, timing=False).equals(clean)


def test_a_table_written_before_versions_were_recorded_counts_as_another_version(
    tmp_path: Path,
) -> None:
    out = tmp_path / "study.parquet"
    run_study(FIRST_HALF, out, grid=GRID, workers=1)
    table = pq.read_table(out)
    old_settings = json.loads(table.schema.metadata[b"xface.study"]) | {"format": 1}
    pq.write_table(  # what xface wrote before: format 1, settings only
        table.replace_schema_metadata({b"xface.study": json.dumps(old_settings).encode()}), out
    )
    assert read_study(out).num_rows == len(FIRST_HALF)  # still readable
    with pytest.raises(xf.XfaceValueError, match="did not record its version"):
        run_study(SPACE, out, grid=GRID, workers=1)
    assert run_study(SPACE, out, grid=GRID, workers=1, allow_version_mix=True).computed == 2


# --- hostile files: a property over truncations, flipped bytes and foreign parts ------------


@st.composite
def damage(draw: st.DrawFn) -> tuple[str, int, list[tuple[float, int]]]:
    """What to do to which file: ``(kind, file index, [(position as a fraction, value)])``."""
    kind = draw(st.sampled_from(["truncate", "flip", "foreign", "none"]))
    which = draw(st.integers(0, 2))  # the table, or one of the two parts
    edits = draw(
        st.lists(st.tuples(st.floats(0, 1, exclude_max=True), st.integers(1, 255)), max_size=3)
    )
    return kind, which, edits or [(0.5, 1)]


def _damage(out: Path, foreign: Path, what: tuple[str, int, list[tuple[float, int]]]) -> None:
    kind, which, edits = what
    target = [out, *_parts(out)][which]
    data = bytearray(target.read_bytes())
    if kind == "truncate":
        target.write_bytes(bytes(data[: int(edits[0][0] * len(data))]))
    elif kind == "flip":
        for where, mask in edits:
            data[int(where * len(data))] ^= mask
        target.write_bytes(bytes(data))
    elif kind == "foreign":
        shutil.copy(foreign, out.with_name(out.name + ".parts") / "f.parquet")


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {str(p): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def hostile(template: Path, foreign_part: Path, clean: Any) -> Any:
    def run(what: tuple[str, int, list[tuple[float, int]]]) -> None:
        with tempfile.TemporaryDirectory() as tmp:
            out = _copy_study(template, Path(tmp))
            _damage(out, foreign_part, what)
            _read_is_clear_or_right(out, clean)
            _resume_is_clear_or_right(out, clean)

    return run


def _read_is_clear_or_right(out: Path, clean: Any) -> None:
    """read_study refuses, or gives rows of the clean table (each design's own), and says
    so when it leaves any out."""
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        try:
            table = read_study(out, timing=False)
        except xf.XfaceValueError:
            event("read_study refused")
            return
    event(f"read_study gave {table.num_rows} rows")
    rows = clean.to_pylist()
    assert all(row in rows for row in table.to_pylist())
    if table.num_rows < len(rows):
        assert any(issubclass(w.category, XfaceWarning) for w in said)


def _resume_is_clear_or_right(out: Path, clean: Any) -> None:
    """A resumed run refuses and changes nothing, or ends with the clean table."""
    before = _snapshot(out.parent)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", XfaceWarning)
        try:
            run_study(SPACE, out, grid=GRID, workers=1)
        except xf.XfaceValueError:
            event("resume refused")
            assert _snapshot(out.parent) == before  # nothing lost, nothing moved
            return
    event("resume completed the table")
    assert read_study(out, timing=False).equals(clean)


@settings(max_examples=80)
@given(what=damage())
def test_a_damaged_or_mixed_study_is_refused_or_read_right_never_crashes(
    hostile: Any, what: tuple[str, int, list[tuple[float, int]]]
) -> None:
    hostile(what)


# --- face files in the table ----------------------------------------------------------------


def _file_face(name: str, h_over_d: float) -> Any:
    from dataclasses import replace

    from xface_core.study.space import FileFace

    return FileFace(f"{name}.yaml", replace(xf.x_face(h_over_d, 2.0), name=name))


def test_two_face_files_of_one_name_are_two_rows_and_resume(tmp_path: Path) -> None:
    files = (_file_face("trap", 0.25), _file_face("trap", 0.5))
    space = DesignSpace(faces=(), h_over_d=(), r_p=(), face_files=files)
    out = tmp_path / "files.parquet"
    assert run_study(space, out, grid=GRID, workers=1).computed == 2
    again = run_study(space, out, grid=GRID, workers=1)
    assert (again.computed, again.skipped) == (0, 2)
    table = read_study(out)
    assert table["face"].to_pylist() == ["trap", "trap"]
    assert sorted(table["face_digest"].to_pylist()) == sorted(f.digest for f in files)
    assert table["h_over_d"].to_pylist() == [None, None]


def test_a_table_written_before_face_files_is_read_and_resumed(tmp_path: Path) -> None:
    from xface_core.study import table as study_table

    out = tmp_path / "old.parquet"
    run_study(FIRST_HALF, out, grid=GRID, workers=1)
    # The same table as the version before face files wrote it: no face_digest column.
    written = pq.read_table(out)
    meta = written.schema.metadata
    old = written.drop_columns(["face_digest"]).replace_schema_metadata(None)
    settings_of_study = json.loads(meta[b"xface.study"])
    writers = json.loads(meta[b"xface.writers"])
    pq.write_table(study_table._with_metadata(old, settings_of_study, writers), out)
    again = run_study(SPACE, out, grid=GRID, workers=1)
    assert (again.computed, again.skipped) == (2, 2)
    assert read_study(out)["face_digest"].to_pylist() == [""] * 4
