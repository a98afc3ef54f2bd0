"""The study table on disk: one Parquet row per design, written as results arrive.

Layout of a study written to ``study.parquet``:

- ``study.parquet``: the compacted table (one file, sorted by design).
- ``study.parquet.parts/``: one small Parquet file per design finished since the last
  compaction, each written to a temporary name and renamed, so a file there is always whole.
  A sweep killed at any moment leaves every finished design on disk; only the designs in
  flight are lost. Every :data:`FOLD_EVERY` parts and at the end of a run the parts are
  folded into the table (a new file renamed over the old one, then the parts removed; a
  crash in between leaves rows twice, which reading deduplicates).

Every file carries the study's settings (pose grid, theta grid, solver settings) in its
Parquet metadata; a run into an output written with other settings is refused, because its
rows would not be comparable. Reading deduplicates by design (a part may survive a crash
between compaction and its removal; rows of one design are equal but for the time).

pyarrow is imported here only (it comes with the ``study`` extra, and with rerun-sdk).
"""

from __future__ import annotations

import json
import os
import uuid
from collections.abc import Mapping, Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

from xface_core.codes import Outcome
from xface_core.errors import XfaceError, XfaceValueError
from xface_core.physics import SolverSettings

from .noise import PoseNoise
from .space import DesignPoint

__all__ = [
    "FOLD_EVERY",
    "KEY_COLUMNS",
    "STUDY_HINT",
    "TIMING_COLUMNS",
    "StudyFile",
    "outcome_column",
    "read_study",
    "require_pyarrow",
    "study_settings",
]

#: The columns that name a design; together they are its key.
KEY_COLUMNS = ("face", "h_over_d", "r_p", "friction", "damping_ratio")

#: Columns that depend on the machine, not on the physics: left out of equality checks.
TIMING_COLUMNS = ("seconds",)

#: Version of the table's layout, stored with the settings.
FORMAT = 1

_META_KEY = b"xface.study"

#: Parts written before they are folded into the table while a study runs: bounds the files
#: a long study leaves in its parts folder (each fold rewrites the table, so not every row).
FOLD_EVERY = 500

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


def _schema(metadata: Mapping[str, Any]) -> Any:
    import pyarrow as pa

    fields: list[tuple[str, Any]] = [
        ("face", pa.string()),
        ("h_over_d", pa.float64()),
        ("r_p", pa.float64()),
        ("friction", pa.float64()),
        ("damping_ratio", pa.float64()),
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
    meta = {_META_KEY: json.dumps(dict(metadata), sort_keys=True).encode()}
    return pa.schema(fields, metadata=meta)


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


class StudyFile:
    """A study table at ``path`` with its parts folder; checks the settings of what is there.

    Raises :class:`XfaceValueError` when the path cannot be written or holds a table of
    another study (other grid or settings, or not an xface study at all).
    """

    def __init__(self, path: str | os.PathLike[str], settings: Mapping[str, Any]) -> None:
        require_pyarrow()
        self.path = Path(path)
        self.parts = self.path.with_name(self.path.name + ".parts")
        self.settings = dict(settings)
        self.fold_every = FOLD_EVERY
        self._unfolded = 0
        self._schema = _schema(self.settings)
        if self.path.is_dir():
            raise XfaceValueError(f"cannot write the study to {self.path}: it is a directory")
        self._check_existing()  # before creating anything
        try:
            self.parts.mkdir(parents=False, exist_ok=True)
            # A part, or a folded table, whose writer was killed before its rename.
            for stale in [*self.parts.glob("*.tmp"), self._folded_tmp()]:
                stale.unlink(missing_ok=True)
        except OSError as exc:
            raise XfaceValueError(f"cannot write the study to {self.path}: {exc}") from None

    def _files(self) -> list[Path]:
        files = sorted(self.parts.glob("*.parquet")) if self.parts.is_dir() else []
        return [self.path, *files] if self.path.exists() else files

    def _check_existing(self) -> None:
        for file in self._files():
            found = _stored_settings(file)
            if found != self.settings:
                raise XfaceValueError(
                    f"{file} belongs to another study ({_difference(found, self.settings)}): "
                    "write this study to another --out"
                )

    def _folded_tmp(self) -> Path:
        return self.path.with_name(self.path.name + ".tmp")

    def done(self) -> set[DesignPoint]:
        """The designs already in the table or its parts."""
        if not self._files():
            return set()
        table = read_study(self.path)
        columns = (table[c].to_pylist() for c in KEY_COLUMNS)
        return {DesignPoint(*key) for key in zip(*columns, strict=True)}

    def write_row(self, row: Mapping[str, Any]) -> None:
        """One finished design, whole or not at all (written aside, then renamed)."""
        import pyarrow as pa
        import pyarrow.parquet as pq

        table = pa.Table.from_pylist([dict(row)], schema=self._schema)
        name = self.parts / f"{uuid.uuid4().hex}.parquet"
        tmp = name.with_suffix(".tmp")
        pq.write_table(table, tmp)
        os.replace(tmp, name)
        self._unfolded += 1
        if self._unfolded >= self.fold_every:
            self.compact(final=False)

    def compact(self, *, final: bool = True) -> None:
        """Fold the parts into the one table file (atomically), then remove them (and, when
        ``final``, their folder)."""
        import pyarrow as pa
        import pyarrow.parquet as pq

        parts = sorted(self.parts.glob("*.parquet"))
        if parts or not self.path.exists():
            table = (
                read_study(self.path).cast(self._schema)
                if parts
                else pa.Table.from_pylist([], schema=self._schema)
            )
            tmp = self._folded_tmp()
            pq.write_table(table, tmp)
            os.replace(tmp, self.path)
            for part in parts:
                part.unlink()
        self._unfolded = 0
        if final:
            self.parts.rmdir()


def _stored_settings(file: Path) -> dict[str, Any]:
    import pyarrow as pa
    import pyarrow.parquet as pq

    try:
        meta = pq.read_schema(file).metadata or {}
    except (OSError, pa.ArrowException) as exc:
        raise XfaceValueError(f"{file} is not a Parquet file ({exc})") from None
    if _META_KEY not in meta:
        raise XfaceValueError(f"{file} is not an xface study table (no study settings in it)")
    stored: dict[str, Any] = json.loads(meta[_META_KEY])
    return stored


def _difference(found: Mapping[str, Any], wanted: Mapping[str, Any]) -> str:
    keys = sorted(k for k in {*found, *wanted} if found.get(k) != wanted.get(k))
    return ", ".join(f"{k} {found.get(k)!r} there, {wanted.get(k)!r} here" for k in keys)


def read_study(path: str | os.PathLike[str], *, timing: bool = True) -> Any:
    """The study table at ``path`` (with the parts of a running or interrupted sweep) as a
    ``pyarrow.Table``, one row per design, sorted by :data:`KEY_COLUMNS`.

    ``timing=False`` drops :data:`TIMING_COLUMNS`: what is left is the same bit for bit
    whatever the executor and the number of workers.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    path = Path(path)
    parts_dir = path.with_name(path.name + ".parts")
    files = sorted(parts_dir.glob("*.parquet")) if parts_dir.is_dir() else []
    if path.exists():
        files.insert(0, path)
    if not files:
        raise XfaceValueError(f"no study table at {path}")
    tables = [pq.read_table(f) for f in files]
    schema = tables[0].schema
    try:
        table = pa.concat_tables([t.cast(schema) for t in tables])
    except (pa.ArrowException, ValueError) as exc:
        raise XfaceValueError(f"{path}: its files do not share one layout ({exc})") from None
    table = table.sort_by([(c, "ascending") for c in KEY_COLUMNS])
    table = table.take(_first_of_each_key(table, KEY_COLUMNS))
    return table.drop_columns(list(TIMING_COLUMNS)) if not timing else table


def _first_of_each_key(table: Any, columns: Sequence[str]) -> list[int]:
    keys = list(zip(*(table[c].to_pylist() for c in columns), strict=True))
    return [i for i, key in enumerate(keys) if i == 0 or key != keys[i - 1]]
