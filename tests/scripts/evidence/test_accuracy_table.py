"""scripts/evidence/accuracy_table.py on the engine runs kept in scripts/evidence/engine_maps/.

The converged engine runs take hours; xface's side of the comparison takes seconds. So CI
compares today's xface with the kept runs of every design: each must meet the bar, and
docs/accuracy.md must be what the script writes today (a change to xface's answers shows up
here, and the table is regenerated with the command in its first line).
"""

from __future__ import annotations

import importlib
import shutil
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest

from xface_core.crosscheck import store
from xface_core.crosscheck.journal import RunJournal

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts" / "evidence"))
table: Any = importlib.import_module("accuracy_table")
DOC = ROOT / "docs" / "accuracy.md"


@pytest.fixture(scope="module")
def regenerated(tmp_path_factory: pytest.TempPathFactory) -> tuple[int, str]:
    """The whole table from a copy of the kept runs (a knife-edge run the copy lacks would
    be added to the copy, not to the repository): the exit code of ``--check`` and the text."""
    tmp = tmp_path_factory.mktemp("accuracy")
    kept = tmp / "engine_maps"
    shutil.copytree(table.STORE, kept)
    out = tmp / "accuracy.md"
    rc = table.main(
        ["--stored-only", "--check", "--quiet", "--store", str(kept), "--out", str(out)]
    )
    return rc, out.read_text()


def _generated_part(text: str) -> str:
    head, marker, _ = text.partition(table.KEEP_MARKER)
    assert marker, "the line that ends the generated part is missing"
    return head


def test_every_kept_design_meets_the_bar(regenerated: tuple[int, str]) -> None:
    rc, _ = regenerated
    assert rc == 0


def test_the_kept_runs_cover_every_row_of_the_committed_table(
    regenerated: tuple[int, str],
) -> None:
    rows = [line for line in DOC.read_text().splitlines() if line.startswith("| ")]
    _, text = regenerated
    assert rows[2:] == [line for line in text.splitlines() if line.startswith("| ")][2:]


def test_docs_accuracy_md_is_todays_comparison(regenerated: tuple[int, str]) -> None:
    _, text = regenerated
    assert _generated_part(DOC.read_text()) == _generated_part(text)


@pytest.fixture(scope="module")
def s_with_friction() -> tuple[Any, Any]:
    """S 0.0625, 1 with mu 0.2 against its kept engine map, before rigid jams are dropped."""
    design = next(d for d in table.DESIGNS if d.label == "S 0.0625, 1, mu 0.2")
    path = table.stored_path(table.STORE, design, 21)
    assert path is not None
    return design, table.compare(design, store.load(path), None)


def test_rigid_jams_leave_the_disagreements_and_are_counted_ambiguous(
    s_with_friction: tuple[Any, Any],
) -> None:
    design, r = s_with_friction
    first_two = replace(r, disagreements=r.disagreements[:2])
    dropped, jams = table.drop_rigid_jams(design, first_two)
    assert [d for d, _ in jams] == list(first_two.disagreements)
    assert dropped.disagreements == ()
    assert dropped.n_ambiguous == r.n_ambiguous + 2
    assert all(dropped.ambiguous[d.index] and not r.ambiguous[d.index] for d, _ in jams)
    assert {v.kind for _, v in jams} <= {"wedge", "pole"}


def test_a_false_seated_is_never_dropped(s_with_friction: tuple[Any, Any]) -> None:
    from xface_core import Outcome

    design, r = s_with_friction
    d = r.disagreements[0]
    seated = replace(d, xface=replace(d.xface, outcome=Outcome.SEATED))
    dropped, jams = table.drop_rigid_jams(design, replace(r, disagreements=(seated,)))
    assert jams == ()
    assert dropped.disagreements == (seated,)


def test_a_false_failure_that_stops_where_the_rigid_model_moves_on_is_kept(
    s_with_friction: tuple[Any, Any],
) -> None:
    # The same cell's xface end moved 0.01 D up along its own contacts: a motion goes on.
    coulomb = importlib.import_module("two_contact_coulomb")
    design, r = s_with_friction
    d = r.disagreements[0]
    stop = coulomb.State(d.xface.phi_b, d.xface.phi_m, d.x0, d.xface.y_m)
    contacts = coulomb.find_contacts(design.build(), stop)
    up, _ = coulomb.on_contacts(design.build(), contacts, stop, stop.y_m + 0.01)
    moved = replace(d, xface=replace(d.xface, phi_b=up.phi_b, phi_m=up.phi_m, y_m=up.y_m))
    dropped, jams = table.drop_rigid_jams(design, replace(r, disagreements=(moved,)))
    assert jams == ()
    assert dropped.disagreements == (moved,)


def test_the_text_after_the_marker_is_kept(tmp_path: Path) -> None:
    kept = tmp_path / "engine_maps"
    kept.mkdir()
    design = table.Design("X", 1.0, 3.0)
    shutil.copy(table.store_path(table.STORE, design, 21), kept)
    out = tmp_path / "accuracy.md"
    out.write_text(f"old table\n{table.KEEP_MARKER}\n## Discussion\n\nBy hand.\n")
    argv = ["--only", "X 1 3", "--stored-only", "--quiet", "--store", str(kept)]
    assert table.main([*argv, "--out", str(out)]) == 0
    text = out.read_text()
    assert text.startswith("# Accuracy")
    assert text.endswith(f"{table.KEEP_MARKER}\n## Discussion\n\nBy hand.\n")
    assert "old table" not in text


def test_runs_kept_under_another_key_are_found_and_named(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    design = table.Design("X", 1.0, 3.0)
    today = table.store_path(table.STORE, design, 21)
    old_key = "0" * 20
    stale = tmp_path / today.name.replace(today.name.split(".")[-2], old_key)
    store.save(stale, replace(store.load(today), key=old_key))
    assert table.stored_path(tmp_path, design, 21) == stale
    evidence, path = table.engine_map(design, 21, tmp_path, quiet=True)
    assert path == stale
    assert evidence.engine.grid == 21
    assert "made with other engine code" in capsys.readouterr().err


def test_an_interrupted_map_resumes_from_its_journal_which_goes_once_stored(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A real 3 x 3 converged map (seconds), stopped after five runs, then run again."""
    design = table.Design("X", 1.0, 3.0)
    journal = table.journal_path(tmp_path, design, 3)
    real_add = RunJournal.add

    def add_then_stop(self: RunJournal, task: Any, run: Any) -> None:
        real_add(self, task, run)
        if len(self) == 5:
            raise KeyboardInterrupt

    monkeypatch.setattr(RunJournal, "add", add_then_stop)
    with pytest.raises(KeyboardInterrupt):
        table.engine_map(design, 3, tmp_path, quiet=False)
    assert len(RunJournal(journal, table._cache_key(design, 3))) == 5
    monkeypatch.setattr(RunJournal, "add", real_add)
    evidence, path = table.engine_map(design, 3, tmp_path, quiet=False)
    assert "resuming with 5 runs kept" in capsys.readouterr().err
    assert path is not None
    assert path.exists()
    assert not journal.exists()
    whole, _ = table.engine_map(design, 3, None, quiet=True)
    assert evidence.engine.step_history == whole.engine.step_history
    assert evidence.engine.sharp == whole.engine.sharp
    assert evidence.engine.rounded == whole.engine.rounded


def _exit_and_err(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    rc = table.main(argv)
    return rc, capsys.readouterr().err


def test_a_damaged_kept_map_is_a_clear_error_not_a_traceback(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    design = table.Design("X", 1.0, 3.0)
    damaged = tmp_path / table.store_path(table.STORE, design, 21).name
    damaged.write_bytes(b"PK\x03\x04 not a zip after all")
    argv = ["--only", "X 1 3", "--stored-only", "--quiet", "--store", str(tmp_path)]
    rc, err = _exit_and_err(argv, capsys)
    assert rc == 2
    assert err.startswith("accuracy_table: error: engine map file ")
    assert damaged.name in err
    assert "Traceback" not in err


def test_a_damaged_journal_is_a_clear_error_before_the_engine_runs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    design = table.Design("X", 1.0, 3.0)
    journal = table.journal_path(tmp_path, design, 3)
    journal.write_text('{"format": "not a journal"}\n')
    rc, err = _exit_and_err(["--only", "X 1 3", "--grid", "3", "--store", str(tmp_path)], capsys)
    assert rc == 2
    assert err.startswith("accuracy_table: error: ")
    assert journal.name in err
    assert not table.store_path(tmp_path, design, 3).exists()  # nothing ran, nothing kept


def test_an_unwritable_out_is_a_clear_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "no such folder" / "accuracy.md"
    argv = ["--only", "X 1 3", "--stored-only", "--quiet", "--out", str(out)]
    rc, err = _exit_and_err(argv, capsys)
    assert rc == 2
    assert "accuracy_table: error: " in err
    assert "no such folder" in err
