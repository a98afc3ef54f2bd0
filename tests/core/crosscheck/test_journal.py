"""journal: engine runs kept as they end, a map resumed from them, hostile files refused."""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import asdict, replace
from pathlib import Path

import pytest

import xface_core as xf
from xface_core.crosscheck import DEFAULT_ENGINE, EngineRun
from xface_core.crosscheck import compare as cc
from xface_core.crosscheck import journal as jr
from xface_core.crosscheck.journal import RunJournal
from xface_core.errors import XfaceValueError

SEAT = EngineRun(xf.Outcome.SEATED, "seated", 0.1, 0.1, 1.0, 0.0, 2.0, 1.0, 40, False)
AWAY = EngineRun(
    xf.Outcome.OUT_OF_REACH, "out of reach", 0.0, 0.3, math.nan, 0.0, 2.0, 0.0, 0, False
)
TASK = (0.25, -0.5, DEFAULT_ENGINE)
OTHER = (0.25, -0.5, DEFAULT_ENGINE.rounded(0.01))
#: Three real cells of X 0.25/2: a seat, a jam and one out of reach.
CELLS = [(0.0, 0.0), (0.95, 1.4), (5.0, 0.0)]


def _journal_with_two(path: Path) -> None:
    with RunJournal(path, "k") as j:
        j.add(TASK, SEAT)
        j.add(OTHER, AWAY)


def test_runs_read_back_field_for_field(
    tmp_path: Path, same_run: Callable[[EngineRun, EngineRun], bool]
) -> None:
    path = tmp_path / "runs.jsonl"
    _journal_with_two(path)
    back = RunJournal(path, "k")
    assert len(back) == 2
    seat, away = back.get(TASK), back.get(OTHER)
    assert seat is not None
    assert same_run(seat, SEAT)
    assert away is not None
    assert same_run(away, AWAY)


def test_a_task_at_other_settings_is_another_task(tmp_path: Path) -> None:
    path = tmp_path / "runs.jsonl"
    with RunJournal(path, "k") as j:
        j.add(TASK, SEAT)
    back = RunJournal(path, "k")
    assert back.get(OTHER) is None
    assert back.get((0.25, -0.5, replace(DEFAULT_ENGINE, step=5e-5))) is None


def test_runs_added_after_reopening_are_appended(tmp_path: Path) -> None:
    path = tmp_path / "runs.jsonl"
    with RunJournal(path, "k") as j:
        j.add(TASK, SEAT)
    with RunJournal(path, "k") as j:
        j.add(OTHER, AWAY)
    assert len(RunJournal(path, "k")) == 2


def test_a_line_cut_off_while_written_is_left_out_and_overwritten(tmp_path: Path) -> None:
    path = tmp_path / "runs.jsonl"
    _journal_with_two(path)
    text = path.read_text()
    path.write_text(text[: len(text) - 40])  # the second run's line cut, no newline
    cut = RunJournal(path, "k")
    assert len(cut) == 1
    assert cut.get(OTHER) is None
    with cut:
        cut.add(OTHER, AWAY)
    assert len(RunJournal(path, "k")) == 2


def test_a_journal_of_another_key_is_not_read_and_is_replaced(
    tmp_path: Path, same_run: Callable[[EngineRun, EngineRun], bool]
) -> None:
    path = tmp_path / "runs.jsonl"
    _journal_with_two(path)
    other = RunJournal(path, "another key")
    assert other.replaced_other
    assert len(other) == 0
    with other:
        other.add(TASK, AWAY)
    assert json.loads(path.read_text().splitlines()[0])["key"] == "another key"
    back = RunJournal(path, "another key")
    assert len(back) == 1
    assert same_run(back.get(TASK) or SEAT, AWAY)


def _line(**change: object) -> str:
    entry: dict[str, object] = {
        "x0": 0.25,
        "theta0": -0.5,
        "settings": asdict(DEFAULT_ENGINE),
        "run": {**asdict(SEAT), "outcome": int(SEAT.outcome)},
    }
    entry.update(change)
    return json.dumps(entry)


def _hostile(path: Path, line: str) -> None:
    header = json.dumps({"format": jr.FORMAT, "version": jr.VERSION, "key": "k"})
    path.write_text(f"{header}\n{_line()}\n{line}\n{_line()}\n")


@pytest.mark.parametrize(
    ("line", "names"),
    [
        ("{not json", "not JSON"),
        ("[1, 2]", "not a run"),
        (_line(x0="0.25"), "x0 is not a number"),
        (_line(theta0=math.inf), "theta0 is not finite"),
        (_line(settings={"step": 1e-4}), "settings must have the fields"),
        (_line(settings={**asdict(DEFAULT_ENGINE), "step": -1.0}), "settings: EngineSettings.step"),
        (_line(run={**asdict(SEAT), "outcome": 99}), "run.outcome is not an outcome code"),
        (_line(run={**asdict(SEAT), "outcome": 0, "steps": -3}), "run.steps is not a count"),
        (_line(run={"outcome": 0}), "run must have the fields"),
        (
            _line(run={**asdict(SEAT), "outcome": 0, "hit_budget": "no"}),
            "run.hit_budget is not true or false",
        ),
    ],
)
def test_a_malformed_line_is_refused_naming_the_file_and_line(
    tmp_path: Path, line: str, names: str
) -> None:
    path = tmp_path / "evil.jsonl"
    _hostile(path, line)
    with pytest.raises(XfaceValueError, match=r"evil\.jsonl: line 3: " + names.replace(".", r"\.")):
        RunJournal(path, "k")


def test_a_file_that_is_not_a_journal_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "notes.jsonl"
    path.write_text('{"format": "something else"}\n')
    with pytest.raises(XfaceValueError, match=r"notes\.jsonl: line 1 is not"):
        RunJournal(path, "k")


def test_a_file_too_large_is_refused_before_it_is_read(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / "big.jsonl"
    _journal_with_two(path)
    monkeypatch.setattr(jr, "MAX_BYTES", 100)
    with pytest.raises(XfaceValueError, match=r"big\.jsonl: \d+ bytes, more than"):
        RunJournal(path, "k")


def test_a_map_resumed_from_its_journal_is_the_map_run_at_once(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    same_run: Callable[[EngineRun, EngineRun], bool],
) -> None:
    """Interrupted after four runs (real engine runs), the map resumes: only the other runs
    are made, and the map is the one made in one go."""
    face = xf.x_face(0.25, 2.0)
    whole = cc.engine_map(face, cells=CELLS, workers=1)
    path = tmp_path / "runs.jsonl"
    real_add = RunJournal.add

    def add_then_stop(self: RunJournal, task: jr.Task, run: EngineRun) -> None:
        real_add(self, task, run)
        if len(self) == 4:
            raise KeyboardInterrupt

    monkeypatch.setattr(RunJournal, "add", add_then_stop)
    with pytest.raises(KeyboardInterrupt), RunJournal(path, "k") as j:
        cc.engine_map(face, cells=CELLS, workers=1, journal=j)
    monkeypatch.setattr(RunJournal, "add", real_add)
    made = []
    real_task = cc._run_task
    monkeypatch.setattr(cc, "_run_task", lambda task: made.append(task) or real_task(task))
    with RunJournal(path, "k") as j:
        assert len(j) == 4
        resumed = cc.engine_map(face, cells=CELLS, workers=1, journal=j)
    assert len(made) == 2 * len(CELLS) - 4
    for side in ("sharp", "rounded"):
        pairs = zip(getattr(resumed, side), getattr(whole, side), strict=True)
        assert all(same_run(a, b) for a, b in pairs)
    assert len(RunJournal(path, "k")) == 2 * len(CELLS)
