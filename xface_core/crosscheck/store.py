"""Engine runs kept as evidence: an :class:`~.compare.EngineMap` and the extra runs of its
knife-edge checks in one ``.npz`` file of plain arrays (no pickles).

The engine's runs depend only on the design's polygons, the physics, the engine's settings
and the scene's code, not on xface; a converged map takes minutes to hours on two cores. Kept
in a file, the comparison with xface (seconds) can be made again after every change to
xface, by anyone, from the same runs (``scripts/evidence/accuracy_table.py`` keeps one file
per design in ``scripts/evidence/engine_maps/``).

A file holds:

* ``meta``: JSON text with the format name and version, the file's key (what the runs depend
  on, hashed by the caller), a label, the provenance in words, the map's grid, settings,
  rounding, convergence, step history, seconds, stall changes and how it converged;
* ``x0``, ``theta0`` (D, rad) and ``changed`` (cells the last halving still changed), one
  entry per cell;
* the sharp and rounded runs, one array per :class:`~.scene.EngineRun` field
  (``sharp_outcome``, ``sharp_reason``, ... ``rounded_hit_budget``);
* the knife-edge probes (``probe_x0``, ``probe_theta0`` and ``probe_<field>``): sharp runs at
  the map's settings from cells beside a disagreeing one (:func:`~.compare.drop_knife_edges`),
  added as xface's disagreements ask for them.

:func:`load` reads it with numpy's pickles refused, after checking that its arrays take at
most :data:`MAX_BYTES`, and checks every array: a file that is not one of these (truncated,
hostile, of another version, too large) raises
:class:`~xface_core.errors.XfaceValueError` naming the file and what is wrong.
"""

from __future__ import annotations

import json
import math
import zipfile
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from xface_core.codes import Outcome
from xface_core.errors import XfaceValueError

from .compare import EngineMap
from .scene import EngineRun, EngineSettings

__all__ = ["FORMAT", "VERSION", "StoredEvidence", "load", "save"]

#: The ``meta`` format name and version this module writes and reads.
FORMAT = "xface-engine-map"
VERSION = 1
#: Largest number of cells (map and probes) a file may hold: far above any map's (a 41 x 41
#: grid is 1681).
MAX_CELLS = 1_000_000
#: Largest size of a file's arrays once read (bytes), checked in the archive's directory
#: before any array is read: a 21 x 21 map with its runs is about 100 kB, and a hostile file
#: (a few kB of zeros compressed) cannot make the reader allocate more than this.
MAX_BYTES = 64 * 2**20

#: One engine run's fields as stored: name and numpy dtype (``reason`` as unicode text).
_RUN_FIELDS: tuple[tuple[str, str], ...] = (
    ("outcome", "i1"),
    ("reason", "U"),
    ("phi_b", "f8"),
    ("phi_m", "f8"),
    ("y_m", "f8"),
    ("x_drift", "f8"),
    ("y_start", "f8"),
    ("descent", "f8"),
    ("steps", "i8"),
    ("hit_budget", "?"),
)

Cell = tuple[float, float]


@dataclass(frozen=True)
class StoredEvidence:
    """What one file holds: the engine's map, its key and label, and the knife-edge probes
    run so far (sharp runs at the map's settings, by the cell they started from: x0 in D,
    theta0 in rad)."""

    key: str
    label: str
    engine: EngineMap
    probes: Mapping[Cell, EngineRun] = field(default_factory=dict)
    provenance: Mapping[str, str] = field(default_factory=dict)
    """What the runs were made with, in words (e.g. the engine's version), for a reader."""


def _columns(prefix: str, runs: list[EngineRun]) -> dict[str, npt.NDArray[Any]]:
    """One array per :class:`~.scene.EngineRun` field, named ``<prefix>_<field>``."""
    out: dict[str, npt.NDArray[Any]] = {}
    for name, dtype in _RUN_FIELDS:
        values = [getattr(r, name) for r in runs]
        if name == "outcome":
            values = [int(v) for v in values]
        out[f"{prefix}_{name}"] = np.asarray(values, dtype=dtype)
    return out


def save(path: Path, evidence: StoredEvidence) -> None:
    """Write ``evidence`` to ``path`` (``.npz``, compressed), through a temporary file beside
    it so that a reader never sees half a file."""
    em = evidence.engine
    probes = sorted(evidence.probes.items())
    meta = {
        "format": FORMAT,
        "version": VERSION,
        "key": evidence.key,
        "label": evidence.label,
        "grid": em.grid,
        "settings": asdict(em.settings),
        "rounding": em.rounding,
        "converged": em.converged,
        "step_history": [[float(s), int(n)] for s, n in em.step_history],
        "seconds": em.seconds,
        "stall_changes": em.stall_changes,
        "converge_by": em.converge_by,
        "provenance": dict(evidence.provenance),
    }
    arrays: dict[str, npt.NDArray[Any]] = {
        "meta": np.asarray(json.dumps(meta, sort_keys=True)),
        "x0": np.asarray(em.x0, dtype=np.float64),
        "theta0": np.asarray(em.theta0, dtype=np.float64),
        "changed": np.asarray(em.changed, dtype=bool),
        "probe_x0": np.asarray([c[0] for c, _ in probes], dtype=np.float64),
        "probe_theta0": np.asarray([c[1] for c, _ in probes], dtype=np.float64),
    }
    arrays |= _columns("sharp", list(em.sharp))
    arrays |= _columns("rounded", list(em.rounded))
    arrays |= _columns("probe", [r for _, r in probes])
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    with tmp.open("wb") as f:
        np.savez_compressed(f, **arrays)  # type: ignore[arg-type]
    tmp.replace(path)


class _Reader:
    """The arrays of one open file, each checked as it is taken."""

    def __init__(self, path: Path, data: Mapping[str, npt.NDArray[Any]]) -> None:
        self.path, self.data = path, data

    def fail(self, what: str) -> XfaceValueError:
        return XfaceValueError(f"engine map file {self.path}: {what}")

    def array(self, name: str, kind: str, n: int | None) -> npt.NDArray[Any]:
        if name not in self.data:
            raise self.fail(f"no array {name!r}")
        a = self.data[name]
        if a.dtype.kind != kind or a.ndim != 1 or (n is not None and a.shape[0] != n):
            want = "" if n is None else f" of length {n}"
            raise self.fail(
                f"array {name!r} is {a.dtype} {a.shape}, not a vector of kind {kind!r}{want}"
            )
        if a.shape[0] > MAX_CELLS:
            raise self.fail(f"array {name!r} has {a.shape[0]} entries (at most {MAX_CELLS})")
        return a

    def runs(self, prefix: str, n: int) -> list[EngineRun]:
        cols = {
            name: self.array(f"{prefix}_{name}", np.dtype(dtype).kind, n)
            for name, dtype in _RUN_FIELDS
        }
        known = {int(o) for o in Outcome}
        bad = set(np.unique(cols["outcome"]).tolist()) - known
        if bad:
            raise self.fail(f"{prefix} runs have unknown outcome codes {sorted(bad)}")
        return [
            EngineRun(
                outcome=Outcome(int(cols["outcome"][k])),
                reason=str(cols["reason"][k]),
                phi_b=float(cols["phi_b"][k]),
                phi_m=float(cols["phi_m"][k]),
                y_m=float(cols["y_m"][k]),
                x_drift=float(cols["x_drift"][k]),
                y_start=float(cols["y_start"][k]),
                descent=float(cols["descent"][k]),
                steps=int(cols["steps"][k]),
                hit_budget=bool(cols["hit_budget"][k]),
            )
            for k in range(n)
        ]

    def meta(self) -> dict[str, Any]:
        raw = self.data.get("meta")
        if raw is None or raw.dtype.kind != "U" or raw.ndim != 0:
            raise self.fail("no 'meta' text")
        try:
            meta = json.loads(str(raw))
        except json.JSONDecodeError as exc:
            raise self.fail(f"'meta' is not JSON ({exc})") from None
        if not isinstance(meta, dict) or meta.get("format") != FORMAT:
            raise self.fail(f"not an engine map (format {FORMAT!r} expected)")
        if meta.get("version") != VERSION:
            raise self.fail(f"format version {meta.get('version')!r}, this reader reads {VERSION}")
        return meta


def _settings(reader: _Reader, raw: object) -> EngineSettings:
    names = {f.name for f in fields(EngineSettings)}
    if not isinstance(raw, dict) or set(raw) != names:
        raise reader.fail(f"settings must have exactly the fields {sorted(names)}")
    for name, value in raw.items():
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise reader.fail(f"setting {name!r} is {value!r}, not a number")
        if not math.isfinite(value):
            raise reader.fail(f"setting {name!r} is {value!r}, not finite")
    return EngineSettings(**raw)


def load(path: Path) -> StoredEvidence:
    """Read a file written by :func:`save` (pickles refused, every array checked)."""
    try:
        with zipfile.ZipFile(path) as archive:
            size = sum(info.file_size for info in archive.infolist())
    except (OSError, zipfile.BadZipFile) as exc:
        raise XfaceValueError(f"engine map file {path}: cannot be read ({exc})") from None
    if size > MAX_BYTES:
        raise XfaceValueError(
            f"engine map file {path}: its arrays take {size} bytes (at most {MAX_BYTES})"
        )
    try:
        with np.load(path, allow_pickle=False) as npz:
            data = {name: npz[name] for name in npz.files}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        raise XfaceValueError(f"engine map file {path}: cannot be read ({exc})") from None
    reader = _Reader(path, data)
    meta = reader.meta()
    x0 = reader.array("x0", "f", None)
    n = x0.shape[0]
    theta0 = reader.array("theta0", "f", n)
    changed = reader.array("changed", "b", n)
    probe_x0 = reader.array("probe_x0", "f", None)
    probe_theta0 = reader.array("probe_theta0", "f", probe_x0.shape[0])
    grid = meta.get("grid")
    if grid is not None and (not isinstance(grid, int) or grid * grid != n):
        raise reader.fail(f"grid {grid!r} does not match its {n} cells")
    history = meta.get("step_history")
    if not isinstance(history, list) or not all(
        isinstance(h, list) and len(h) == 2 for h in history
    ):
        raise reader.fail("'step_history' must be a list of [step, changed cells]")
    try:
        engine = EngineMap(
            x0=x0.copy(),
            theta0=theta0.copy(),
            grid=grid,
            sharp=tuple(reader.runs("sharp", n)),
            rounded=tuple(reader.runs("rounded", n)),
            settings=_settings(reader, meta.get("settings")),
            rounding=float(meta["rounding"]),
            changed=changed.copy(),
            converged=None if meta["converged"] is None else bool(meta["converged"]),
            step_history=tuple((float(s), int(c)) for s, c in history),
            seconds=float(meta["seconds"]),
            stall_changes=None if meta["stall_changes"] is None else int(meta["stall_changes"]),
            converge_by=str(meta["converge_by"]),
        )
    except (KeyError, TypeError, ValueError) as exc:
        raise reader.fail(f"'meta' is incomplete or wrong ({exc!r})") from None
    probe_runs = reader.runs("probe", probe_x0.shape[0])
    probes = {
        (float(x), float(t)): r
        for x, t, r in zip(probe_x0.tolist(), probe_theta0.tolist(), probe_runs, strict=True)
    }
    raw = meta.get("provenance", {})
    if not isinstance(raw, dict) or not all(isinstance(v, str) for v in raw.values()):
        raise reader.fail("'provenance' must map names to text")
    key, label = str(meta.get("key", "")), str(meta.get("label", ""))
    return StoredEvidence(key, label, engine, probes, {str(k): v for k, v in raw.items()})
