"""scripts/evidence/check_atlas.py: its chord check reports every design on one line (the
full run's findings are in docs/atlas.md, never asserted)."""

from __future__ import annotations

import importlib
import re
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts" / "evidence"))
check = importlib.import_module("check_atlas")


def test_the_chord_check_prints_one_line_per_design(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(check, "CHORD_DESIGNS", (("V", 0.5, 1.0),))
    check.check_chords(200, np.random.default_rng(0))
    [line] = capsys.readouterr().out.splitlines()
    found = re.fullmatch(
        r"CHORDS V 0.5/1: (\d+) boundary cells, (\d+) set aside by the check \([\d.]+ s\); "
        r"of 200 poses in boundary cells on the wrong side: ([\d.]+)% unchecked, ([\d.]+)% "
        r"checked \(([\d.]+)% simulated\)",
        line,
    )
    assert found, line
    cells, aside = int(found[1]), int(found[2])
    assert cells > 0
    assert 0 <= aside <= cells
    # The check only sets cells aside: the share on the wrong side cannot grow.
    assert float(found[4]) <= float(found[3])
