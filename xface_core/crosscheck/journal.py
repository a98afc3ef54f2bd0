"""Engine runs written down as they finish, so that a map of hours can be resumed.

A converged engine map runs every cell at the default step and again at each halving, then
the jammed cells at a slower stall speed (:func:`~.compare.engine_map`): minutes for most
designs, hours for the finest with friction. A :class:`RunJournal` keeps every run the
moment it ends, one JSON line each; :func:`~.compare.run_engine` takes the runs it finds
there and runs only the others. A run interrupted (a session's end, a killed process, a full
disk) loses at most the runs under way.

A run is a pure function of the design's polygons, the physics, the engine's settings, the
scene's code and the cell. The first line of the file holds a ``key`` hashing all of those
but the cell (the caller's: ``scripts/evidence/accuracy_table.py`` uses the key of its
stored maps); each later line one run: the cell (x0 in D, theta0 in rad), the settings
(every field of :class:`~.scene.EngineSettings`) and the run (every field of
:class:`~.scene.EngineRun`). A file made for another key is not read: it is replaced as the
first run is written.

Reading checks every line and raises :class:`~xface_core.errors.XfaceValueError` naming the
file and the line for anything that is not such a run. The one exception is a last line
without its newline: a run cut off while being written, left out.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, fields
from pathlib import Path
from typing import Any, TextIO

from xface_core.codes import Outcome
from xface_core.errors import XfaceValueError

from .scene import EngineRun, EngineSettings

__all__ = ["FORMAT", "MAX_BYTES", "VERSION", "RunJournal", "Task"]

#: The first line's format name and version.
FORMAT = "xface-engine-journal"
VERSION = 1
#: Largest journal read (bytes): a 21 x 21 map's every pass is about 2 MB.
MAX_BYTES = 256 * 2**20

#: One engine run asked for: x0 (D), theta0 (rad) and the settings it runs at.
Task = tuple[float, float, EngineSettings]

_SETTINGS_FIELDS = tuple(f.name for f in fields(EngineSettings))
_RUN_FIELDS = tuple(f.name for f in fields(EngineRun))
_OUTCOME_CODES = frozenset(int(o) for o in Outcome)


class RunJournal:
    """The runs kept in ``path`` for ``key``, and the file the next ones are added to.

    Use as a context manager (or call :meth:`close`): the file is open for appending from the
    first :meth:`add` on.
    """

    def __init__(self, path: Path, key: str) -> None:
        self.path = Path(path)
        self.key = key
        self._runs: dict[Task, EngineRun] = {}
        self._file: TextIO | None = None
        #: Was a file there made for another key (or version), and so not read?
        self.replaced_other = False
        if self.path.exists():
            self._read()

    def __enter__(self) -> RunJournal:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __len__(self) -> int:
        return len(self._runs)

    def get(self, task: Task) -> EngineRun | None:
        """The run kept for ``task``, or None."""
        return self._runs.get(_task_key(task))

    def add(self, task: Task, run: EngineRun) -> None:
        """Keep ``run`` as the answer to ``task``, written to the file at once (flushed)."""
        if self._file is None:
            self._file = self._open_for_writing()
        key = _task_key(task)
        self._runs[key] = run
        x0, theta0, settings = key
        line = {"x0": x0, "theta0": theta0, "settings": asdict(settings), "run": _run_dict(run)}
        self._file.write(json.dumps(line, allow_nan=True) + "\n")
        self._file.flush()

    def close(self) -> None:
        """Close the file (the runs read stay available)."""
        if self._file is not None:
            self._file.close()
            self._file = None

    def _open_for_writing(self) -> TextIO:
        """The file to add runs to: this key's, after its last complete line (a line cut off
        while written is dropped), or a new one with this key's header."""
        if self.path.exists() and not self.replaced_other:
            with self.path.open("rb+") as f:
                data = f.read()
                f.truncate(data.rfind(b"\n") + 1)
            return self.path.open("a", encoding="utf-8")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        file = self.path.open("w", encoding="utf-8")
        file.write(json.dumps({"format": FORMAT, "version": VERSION, "key": self.key}) + "\n")
        file.flush()
        self.replaced_other = False
        return file

    def _read(self) -> None:
        size = self.path.stat().st_size
        if size > MAX_BYTES:
            raise XfaceValueError(
                f"{self.path}: {size} bytes, more than a run journal may hold ({MAX_BYTES})"
            )
        try:
            text = self.path.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as e:
            raise XfaceValueError(f"{self.path}: not a run journal ({e})") from e
        lines = text.split("\n")
        # The piece after the last newline: empty, or a run cut off while written.
        complete = lines[:-1]
        if not complete:
            self.replaced_other = True  # empty, or only a cut header: written afresh
            return
        if not self._header_matches(complete[0]):
            self.replaced_other = True
            return
        for number, line in enumerate(complete[1:], start=2):
            if not line.strip():
                continue
            task, run = _parse_run(line, f"{self.path}: line {number}")
            self._runs[task] = run

    def _header_matches(self, line: str) -> bool:
        try:
            header = json.loads(line)
        except ValueError as e:
            raise XfaceValueError(f"{self.path}: line 1 is not a journal's header ({e})") from e
        if not isinstance(header, dict) or header.get("format") != FORMAT:
            raise XfaceValueError(f"{self.path}: line 1 is not a {FORMAT} header")
        return bool(header.get("version") == VERSION and header.get("key") == self.key)


def _task_key(task: Task) -> Task:
    x0, theta0, settings = task
    return (float(x0), float(theta0), settings)


def _run_dict(run: EngineRun) -> dict[str, Any]:
    values = asdict(run)
    values["outcome"] = int(run.outcome)
    return values


def _parse_run(line: str, where: str) -> tuple[Task, EngineRun]:
    """One line's task and run, every field checked; ``where`` names the line in errors."""
    try:
        entry = json.loads(line)
    except ValueError as e:
        raise XfaceValueError(f"{where}: not JSON ({e})") from e
    if not isinstance(entry, dict) or set(entry) != {"x0", "theta0", "settings", "run"}:
        raise XfaceValueError(f"{where}: not a run (x0, theta0, settings, run)")
    x0, theta0 = entry["x0"], entry["theta0"]
    for name, value in (("x0", x0), ("theta0", theta0)):
        if not (isinstance(value, float | int) and not isinstance(value, bool)):
            raise XfaceValueError(f"{where}: {name} is not a number")
        if not math.isfinite(value):
            raise XfaceValueError(f"{where}: {name} is not finite")
    settings = entry["settings"]
    if not isinstance(settings, dict) or set(settings) != set(_SETTINGS_FIELDS):
        raise XfaceValueError(f"{where}: settings must have the fields {_SETTINGS_FIELDS}")
    try:
        engine_settings = EngineSettings(**settings)
    except (TypeError, XfaceValueError) as e:
        raise XfaceValueError(f"{where}: settings: {e}") from e
    return (float(x0), float(theta0), engine_settings), _engine_run(entry["run"], where)


def _engine_run(values: object, where: str) -> EngineRun:
    if not isinstance(values, dict) or set(values) != set(_RUN_FIELDS):
        raise XfaceValueError(f"{where}: run must have the fields {_RUN_FIELDS}")
    outcome = values["outcome"]
    if isinstance(outcome, bool) or not isinstance(outcome, int) or outcome not in _OUTCOME_CODES:
        raise XfaceValueError(f"{where}: run.outcome is not an outcome code")
    if not isinstance(values["reason"], str):
        raise XfaceValueError(f"{where}: run.reason is not text")
    for name in ("phi_b", "phi_m", "y_m", "x_drift", "y_start", "descent"):
        value = values[name]
        if isinstance(value, bool) or not isinstance(value, float | int):
            raise XfaceValueError(f"{where}: run.{name} is not a number")
    steps = values["steps"]
    if isinstance(steps, bool) or not isinstance(steps, int) or steps < 0:
        raise XfaceValueError(f"{where}: run.steps is not a count")
    if not isinstance(values["hit_budget"], bool):
        raise XfaceValueError(f"{where}: run.hit_budget is not true or false")
    return EngineRun(
        outcome=Outcome(outcome),
        reason=values["reason"],
        phi_b=float(values["phi_b"]),
        phi_m=float(values["phi_m"]),
        y_m=float(values["y_m"]),
        x_drift=float(values["x_drift"]),
        y_start=float(values["y_start"]),
        descent=float(values["descent"]),
        steps=steps,
        hit_budget=values["hit_budget"],
    )
