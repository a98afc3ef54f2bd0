"""The study table on disk: one Parquet row per design, written as results arrive.

Layout of a study written to ``study.parquet``:

- ``study.parquet``: the compacted table (one file, sorted by design).
- ``study.parquet.parts/``: one small Parquet file per design finished since the last
  compaction, each written to a temporary name and renamed, so a file there is always whole.
  A sweep killed at any moment leaves every finished design on disk; only the designs in
  flight are lost. Every :data:`FOLD_EVERY` parts and at the end of a run the parts are
  folded into the table (a new file renamed over the old one, then the parts removed; a
  crash in between leaves rows twice, which reading deduplicates).
- ``study.parquet.lock``: while a run writes the study, its lock (:mod:`.lock`): a second
  run into the same output is refused.
- ``study.parquet.quarantine/``: parts a run set aside, never deleted: a damaged part (its
  design is computed again) or one whose row contradicts another row of its design.

Every file carries, in its Parquet metadata, the study's settings (pose grid, theta grid,
solver settings, pose noise), the versions that wrote its rows (xface and the digest of the
engine's sources) and a SHA-256 of all that and of its rows. Every file is checked on every
read, by one function (:func:`load_study`) for :func:`read_study` and for a run resuming:

- unreadable, or not matching its checksum: the table is refused (it may hold every row);
  a part is left out with a warning by :func:`read_study`, moved to the quarantine by a run;
- written with other settings (another study's file): refused, naming the file;
- a second row of a design that differs from the first (not just in ``seconds``): the first
  is kept (the table's before any part's), with a warning naming the design; a run moves
  the other part to the quarantine.

A run refuses an output holding rows of another xface or engine version unless told
``allow_version_mix``. Files written before versions were recorded (``format`` 1) have no
checksum and count as of an unrecorded version.

pyarrow is imported here only (it comes with the ``study`` extra, and with rerun-sdk).
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import json
import os
import uuid
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from xface_core.codes import Outcome
from xface_core.errors import XfaceError, XfaceValueError, XfaceWarning
from xface_core.physics import SolverSettings

from .lock import StudyLock
from .noise import PoseNoise
from .space import DesignPoint

__all__ = [
    "FOLD_EVERY",
    "KEY_COLUMNS",
    "STUDY_HINT",
    "TIMING_COLUMNS",
    "StudyFile",
    "load_study",
    "outcome_column",
    "read_study",
    "require_pyarrow",
    "study_settings",
    "study_writers",
    "writer_version",
]

#: The columns that name a design; together they are its key.
KEY_COLUMNS = ("face", "h_over_d", "r_p", "friction", "damping_ratio", "face_digest")

#: Columns that depend on the machine, not on the physics: left out of equality checks.
TIMING_COLUMNS = ("seconds",)

#: Version of the table's layout, stored with the settings. 2: versions and checksum added.
FORMAT = 2

_META_KEY = b"xface.study"
_WRITERS_KEY = b"xface.writers"
_DIGEST_KEY = b"xface.sha256"

#: The version of rows in a file written before versions were recorded (format 1).
UNRECORDED = {"xface": "unrecorded", "engine": "unrecorded"}

#: Parts written before they are folded into the table while a study runs: bounds the files
#: a long study leaves in its parts folder (each fold rewrites the table, so not every row).
FOLD_EVERY = 500

#: Times a read starts again when a part vanished under it (folded by the run writing it).
_READ_ATTEMPTS = 5

#: What to install for studies.
STUDY_HINT = "pip install '.[study]' in the xface checkout"


def require_pyarrow() -> None:
    """Raise :class:`~xface_core.errors.XfaceError` naming the extra if pyarrow is missing."""
    try:
        import pyarrow.parquet  # noqa: F401
    except ImportError:
        raise XfaceError(f"design studies need the study extra (pyarrow): {STUDY_HINT}") from None


def outcome_column(outcome: Outcome) -> str:
    """The table column counting the cells of ``outcome`` (``n_seated``, ...)."""
    return f"n_{outcome.name.lower()}"


def _schema(*, digest: bool = True) -> Any:
    """The columns of a study table; without ``digest``, those of a table written before
    face files joined the studies (read as if every row had an empty ``face_digest``)."""
    import pyarrow as pa

    fields: list[tuple[str, Any]] = [
        ("face", pa.string()),
        ("h_over_d", pa.float64()),
        ("r_p", pa.float64()),
        ("friction", pa.float64()),
        ("damping_ratio", pa.float64()),
        *([("face_digest", pa.string())] if digest else []),
        ("M", pa.int64()),
        *((outcome_column(o), pa.int64()) for o in Outcome),
    ]
    for region in ("guaranteed", "centred"):
        fields.append((f"{region}_cells", pa.int64()))
        fields += [
            (f"{region}_{axis}_{end}", pa.float64())
            for axis in ("x0", "theta0")
            for end in ("min", "max")
        ]
    fields += [("seat_probability", pa.float64()), ("seat_probability_se", pa.float64())]
    fields.append(("seconds", pa.float64()))
    return pa.schema(fields)


def study_settings(
    grid: int, theta_kind: str, settings: SolverSettings, noise: PoseNoise | None = None
) -> dict[str, Any]:
    """What every row of a study shares, stored in each file's metadata."""
    return {
        "format": FORMAT,
        "grid": grid,
        "theta_grid": theta_kind,
        "settings": asdict(settings),
        "pose_noise": None if noise is None else noise.as_dict(),
    }


@functools.cache
def writer_version() -> dict[str, str]:
    """This process's versions as stored with the rows it writes: ``xface`` (the installed
    distribution's version) and ``engine`` (SHA-256 of the engine's sources)."""
    from xface_core.runner import engine_digest, xface_version

    return {"xface": xface_version(), "engine": engine_digest()}


def describe_writers(writers: Sequence[Mapping[str, str]]) -> str:
    """``xface 0.1.0 (engine 1a2b3c4d5e6f)``, joined by "and"."""
    return " and ".join(
        "an xface that did not record its version"
        if dict(w) == UNRECORDED
        else f"xface {w['xface']} (engine {w['engine'][:12]})"
        for w in writers
    )


def _writers_json(writers: Sequence[Mapping[str, str]]) -> bytes:
    unique = {json.dumps(dict(w), sort_keys=True) for w in writers}
    return json.dumps([json.loads(w) for w in sorted(unique)]).encode()


def _rows_digest(settings_json: bytes, writers_json: bytes, table: Any) -> str:
    """SHA-256 of a file's settings, versions and rows (every column, nulls as such): the
    same for the table written and the table read back, whatever its chunks."""
    import numpy as np
    import pyarrow as pa

    h = hashlib.sha256()
    for blob in (settings_json, writers_json):
        h.update(len(blob).to_bytes(8, "little") + blob)
    h.update(table.num_rows.to_bytes(8, "little"))
    for name in table.column_names:
        column = table[name]
        h.update(name.encode() + b"\0")
        h.update(np.asarray(column.is_null(), dtype=bool).tobytes())
        if pa.types.is_string(column.type):
            h.update("\0".join(column.fill_null("").to_pylist()).encode())
        else:
            h.update(np.asarray(column.fill_null(0).to_numpy()).tobytes())
    return h.hexdigest()


def _with_metadata(
    table: Any, settings: Mapping[str, Any], writers: Sequence[Mapping[str, str]]
) -> Any:
    """``table`` carrying ``settings``, ``writers`` and the checksum of them and its rows."""
    settings_json = json.dumps(dict(settings), sort_keys=True).encode()
    writers_json = _writers_json(writers)
    digest = _rows_digest(settings_json, writers_json, table)
    return table.replace_schema_metadata(
        {_META_KEY: settings_json, _WRITERS_KEY: writers_json, _DIGEST_KEY: digest.encode()}
    )


class _Damaged(Exception):
    """A file of a study that cannot be read or does not match its checksum (its reason)."""


class _NotAStudy(_Damaged):
    """A readable Parquet file that is no xface study table (what it lacks)."""


@dataclass(frozen=True)
class _Piece:
    """One file of a study, read and checked."""

    file: Path
    table: Any
    settings: dict[str, Any]
    writers: tuple[dict[str, str], ...]


def _read_piece(file: Path) -> _Piece:
    """``file`` read whole and checked; :class:`_Damaged` when it cannot be trusted.
    FileNotFoundError passes (a part folded away meanwhile)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    try:
        table = pq.read_table(file)
    except FileNotFoundError:
        raise
    except (OSError, pa.ArrowException, ValueError, EOFError) as exc:
        raise _Damaged(f"not a readable Parquet file ({str(exc).rstrip('.')})") from None
    meta = table.schema.metadata or {}
    if _META_KEY not in meta:
        raise _NotAStudy("no study settings in it")
    columns = table.schema.remove_metadata()
    before_face_files = columns.equals(_schema(digest=False))
    if not (before_face_files or columns.equals(_schema())):
        raise _NotAStudy("its columns are not those of a study table")
    try:
        settings = json.loads(meta[_META_KEY])
        if not isinstance(settings, dict):
            raise ValueError("not a mapping")
        if settings.get("format") == 1:  # written before versions and checksums
            writers: tuple[dict[str, str], ...] = (dict(UNRECORDED),)
        else:
            writers = tuple(json.loads(meta[_WRITERS_KEY]))
            stored = meta[_DIGEST_KEY].decode()
            if _rows_digest(meta[_META_KEY], meta[_WRITERS_KEY], table) != stored:
                raise _Damaged("its contents do not match its checksum")
    except (KeyError, ValueError, TypeError, UnicodeDecodeError) as exc:
        raise _Damaged(f"its study metadata is unreadable ({exc})") from None
    if before_face_files:  # checked as written; then read as a table of today
        digests = pa.array([""] * table.num_rows, pa.string())
        table = table.add_column(KEY_COLUMNS.index("face_digest"), "face_digest", digests)
    return _Piece(file, table, settings, writers)


def _comparable(settings: Mapping[str, Any]) -> dict[str, Any]:
    """The settings that make two files one study (the layout's format does not)."""
    return {k: v for k, v in settings.items() if k != "format"}


def _difference(found: Mapping[str, Any], wanted: Mapping[str, Any], here: str) -> str:
    found, wanted = _comparable(found), _comparable(wanted)
    keys = sorted(k for k in {*found, *wanted} if found.get(k) != wanted.get(k))
    return ", ".join(f"{k} {found.get(k)!r} there, {wanted.get(k)!r} {here}" for k in keys)


def _study_files(path: Path) -> list[Path]:
    """The table (first) and the parts of the study at ``path`` that exist."""
    parts_dir = path.with_name(path.name + ".parts")
    files = sorted(parts_dir.glob("*.parquet")) if parts_dir.is_dir() else []
    return [path, *files] if path.exists() else files


def load_study(
    path: str | os.PathLike[str],
    expected: Mapping[str, Any] | None,
    damaged_part: Callable[[Path, str], None],
) -> list[Any]:
    """Every file of the study at ``path``, each read and checked (the one check of reading
    and of resuming): the table first, then the parts.

    ``expected``: the settings of the study (a run's); None takes the first file's (the
    table's when there is one). ``damaged_part(file, reason)`` is called for a part that
    cannot be read or does not match its checksum, which is then left out.

    Raises
    ------
    XfaceValueError
        The table is damaged, or a file belongs to another study (other settings).
    """
    path = Path(path)
    for _ in range(_READ_ATTEMPTS):
        try:
            pieces = _load_once(path, damaged_part)
            break
        except FileNotFoundError:
            continue  # a part folded into the table meanwhile by the run writing it: again
    else:
        raise XfaceValueError(f"{path}: its files kept changing while being read; try again")
    reference = expected
    if reference is None and pieces:
        reference = pieces[0].settings
    for piece in pieces:
        if reference is not None and _comparable(piece.settings) != _comparable(reference):
            here = "here" if expected is not None else f"in {pieces[0].file.name}"
            advice = (
                "write this study to another --out"
                if piece.file == path
                else f"move it out of {piece.file.parent} (this study's parts go there)"
            )
            raise XfaceValueError(
                f"{piece.file} belongs to another study "
                f"({_difference(piece.settings, reference, here)}): {advice}"
            )
    return pieces


def _load_once(path: Path, damaged_part: Callable[[Path, str], None]) -> list[_Piece]:
    pieces = []
    for file in _study_files(path):
        try:
            pieces.append(_read_piece(file))
        except _Damaged as exc:
            foreign = isinstance(exc, _NotAStudy)
            reason = f"not an xface study table ({exc})" if foreign else str(exc)
            if file != path:
                damaged_part(file, reason)
                continue
            if foreign:
                message = f"{file} is {reason}: write this study to another --out"
                raise XfaceValueError(message) from None
            raise XfaceValueError(
                f"{file} is damaged: {exc}; restore it from a copy, or move it aside to "
                "start the study over"
            ) from None
    return pieces


def _design_text(key: Sequence[Any]) -> str:
    return ", ".join(f"{k}={v}" for k, v in zip(KEY_COLUMNS, key, strict=True))


def _merge(pieces: Sequence[_Piece]) -> tuple[Any, list[tuple[Path, str]]]:
    """One row per design, sorted by :data:`KEY_COLUMNS`: the first of each design (the
    table's before the parts'), and the files whose row of a design differs from that first
    one (not just in :data:`TIMING_COLUMNS`), each with what differs."""
    import pyarrow as pa

    schema = _schema()
    tables = [
        p.table.cast(schema).append_column("__piece", pa.array([i] * p.table.num_rows, pa.int64()))
        for i, p in enumerate(pieces)
    ]
    if not tables:
        return schema.empty_table(), []
    order = [(c, "ascending") for c in (*KEY_COLUMNS, "__piece")]  # the table's rows first
    table = pa.concat_tables(tables).sort_by(order)
    keys = list(zip(*(table[c].to_pylist() for c in KEY_COLUMNS), strict=True))
    firsts = [i for i, key in enumerate(keys) if i == 0 or key != keys[i - 1]]
    conflicts = []
    compared = [c for c in schema.names if c not in TIMING_COLUMNS]
    first = 0
    for i in range(len(keys)):
        if i == 0 or keys[i] != keys[i - 1]:
            first = i
            continue
        kept, other = (table.slice(j, 1).to_pylist()[0] for j in (first, i))
        differ = [c for c in compared if json.dumps(kept[c]) != json.dumps(other[c])]
        if differ:
            kept_file = pieces[kept["__piece"]].file
            if other["__piece"] == kept["__piece"]:  # only a table holds more than one row
                raise XfaceValueError(
                    f"{kept_file} is damaged: two different rows of design "
                    f"{_design_text(keys[i])}; restore it from a copy, or move it aside to "
                    "start the study over"
                )
            what = ", ".join(f"{c} {kept[c]!r} there, {other[c]!r} here" for c in differ)
            conflicts.append(
                (
                    pieces[other["__piece"]].file,
                    (
                        f"its row of design {_design_text(keys[i])} differs from the one "
                        f"kept, in {kept_file} ({what})"
                    ),
                )
            )
    return table.take(firsts).drop_columns(["__piece"]), conflicts


def study_writers(pieces: Sequence[Any]) -> list[dict[str, str]]:
    """The versions that wrote the rows of ``pieces`` (of :func:`load_study`), each once."""
    return [dict(w) for w in json.loads(_writers_json([w for p in pieces for w in p.writers]))]


def _warn_left_out(file: Path, reason: str) -> None:
    warnings.warn(
        f"{file} is left out: {reason}; running the study again moves it aside and "
        "computes its design again",
        XfaceWarning,
        stacklevel=4,
    )


def read_study(path: str | os.PathLike[str], *, timing: bool = True) -> Any:
    """The study table at ``path`` (with the parts of a running or interrupted sweep) as a
    ``pyarrow.Table``, one row per design, sorted by :data:`KEY_COLUMNS`.

    ``timing=False`` drops :data:`TIMING_COLUMNS`: what is left is the same bit for bit
    whatever the executor and the number of workers. Every file is checked
    (:func:`load_study`): a damaged part, or a part whose row of a design differs from the
    row kept, is left out with an :class:`~xface_core.errors.XfaceWarning`. The table's
    schema metadata holds the study's settings (``xface.study``) and the versions that
    wrote its rows (``xface.writers``, JSON).

    Raises
    ------
    XfaceValueError
        No study at ``path``, its table is damaged, or a file is of another study.
    """
    path = Path(path)
    if not _study_files(path):
        raise XfaceValueError(f"no study table at {path}")
    pieces = load_study(path, None, _warn_left_out)
    if not pieces:
        raise XfaceValueError(f"no readable study table at {path}: its parts are damaged")
    table, conflicts = _merge(pieces)
    for file, why in conflicts:
        _warn_left_out(file, why)
    settings_json = json.dumps(pieces[0].settings, sort_keys=True).encode()
    writers_json = _writers_json(study_writers(pieces))
    table = table.replace_schema_metadata({_META_KEY: settings_json, _WRITERS_KEY: writers_json})
    return table.drop_columns(list(TIMING_COLUMNS)) if not timing else table


class StudyFile:
    """A study table at ``path`` with its parts folder, locked for this run (a context
    manager: :meth:`close` releases the lock); checks what is there (:func:`load_study`).

    Raises :class:`XfaceValueError` when the path cannot be written, holds a damaged table or
    a file of another study (other grid or settings, or not an xface study at all), or rows
    of another xface or engine version (unless ``allow_version_mix``), and
    :class:`~xface_core.study.lock.StudyBusy` when another run writes it.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        settings: Mapping[str, Any],
        *,
        allow_version_mix: bool = False,
    ) -> None:
        require_pyarrow()
        self.path = Path(path)
        self.parts = self.path.with_name(self.path.name + ".parts")
        self.quarantine = self.path.with_name(self.path.name + ".quarantine")
        self.settings = dict(settings)
        self.writer = writer_version()
        self.fold_every = FOLD_EVERY
        self._unfolded = 0
        if self.path.is_dir():
            raise XfaceValueError(f"cannot write the study to {self.path}: it is a directory")
        self._lock = StudyLock(self.path)
        self._lock.acquire()  # before reading anything: nobody else changes it from here
        try:
            table, writers, _ = self._fold_check()
            self._check_versions(writers, allow_version_mix)
            columns = (table[c].to_pylist() for c in KEY_COLUMNS)
            self._done = {DesignPoint(*key) for key in zip(*columns, strict=True)}
            self._rows: list[dict[str, Any]] = table.to_pylist()
            self.parts.mkdir(parents=False, exist_ok=True)
            # A part, or a folded table, whose writer was killed before its rename.
            for stale in [*self.parts.glob("*.tmp"), self._folded_tmp()]:
                stale.unlink(missing_ok=True)
        except OSError as exc:
            self.close()
            raise XfaceValueError(f"cannot write the study to {self.path}: {exc}") from None
        except BaseException:
            self.close()
            raise

    def close(self) -> None:
        """Release the lock (idempotent)."""
        self._lock.release()

    def __enter__(self) -> StudyFile:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def _folded_tmp(self) -> Path:
        return self.path.with_name(self.path.name + ".tmp")

    def _set_aside(self, file: Path, reason: str) -> None:
        """Move a part into the quarantine folder, with a warning: nothing is deleted."""
        target = self.quarantine / file.name
        try:
            self.quarantine.mkdir(exist_ok=True)
            os.replace(file, target)
        except OSError as exc:
            raise XfaceValueError(
                f"{file}: {reason}, and it cannot be moved aside: {exc}"
            ) from None
        warnings.warn(
            f"{file}: {reason}; moved it to {target} (a design of it that the rest of the "
            "study lacks is computed again)",
            XfaceWarning,
            stacklevel=3,
        )

    def _fold_check(self) -> tuple[Any, list[dict[str, str]], list[Path]]:
        """The study's rows (one per design), their versions and the parts they came from,
        every file checked; damaged and contradicting parts moved to the quarantine."""
        pieces = load_study(self.path, self.settings, self._set_aside)
        table, conflicts = _merge(pieces)
        for file, why in conflicts:
            self._set_aside(file, why)
        moved = {file for file, _ in conflicts}
        parts = [p.file for p in pieces if p.file != self.path and p.file not in moved]
        return table, study_writers(pieces), parts

    def _check_versions(self, writers: Sequence[Mapping[str, str]], allowed: bool) -> None:
        others = [w for w in writers if dict(w) != self.writer]
        if others and not allowed:
            raise XfaceValueError(
                f"{self.path} holds rows written by {describe_writers(others)}, and this is "
                f"{describe_writers([self.writer])}: rows of another engine may differ. Write "
                "this study to another --out, or pass --allow-version-mix (API: "
                "allow_version_mix=True) to add this version's rows to it"
            )

    def done(self) -> set[DesignPoint]:
        """The designs already in the table or its parts when this run started."""
        return set(self._done)

    def rows(self) -> list[dict[str, Any]]:
        """The rows already in the table or its parts when this run started (one per design,
        checked as :meth:`done`'s)."""
        return [dict(row) for row in self._rows]

    def write_row(self, row: Mapping[str, Any]) -> None:
        """One finished design, whole or not at all (written aside, then renamed)."""
        import pyarrow as pa
        import pyarrow.parquet as pq

        table = pa.Table.from_pylist([dict(row)], schema=_schema())
        name = self.parts / f"{uuid.uuid4().hex}.parquet"
        tmp = name.with_suffix(".tmp")
        pq.write_table(_with_metadata(table, self.settings, [self.writer]), tmp)
        os.replace(tmp, name)
        self._unfolded += 1
        if self._unfolded >= self.fold_every:
            self.compact(final=False)

    def compact(self, *, final: bool = True) -> None:
        """Fold the parts into the one table file (atomically), then remove them (and, when
        ``final``, their folder)."""
        import pyarrow.parquet as pq

        if any(self.parts.glob("*.parquet")) or not self.path.exists():
            table, writers, parts = self._fold_check()
            tmp = self._folded_tmp()
            pq.write_table(_with_metadata(table, self.settings, writers or [self.writer]), tmp)
            os.replace(tmp, self.path)
            for part in parts:
                part.unlink()
        self._unfolded = 0
        if final:
            # A folder still holding files that are not parts of the study stays.
            with contextlib.suppress(OSError):
                self.parts.rmdir()
