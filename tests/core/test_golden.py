"""The redesign guard: maps, final states and paths equal the golden outputs stored before it.

The golden file was written by ``python scripts/evidence/golden_maps.py --write`` on the engine
before its redesign; every behaviour-preserving change of the engine must keep this test green.
A change that is *meant* to change answers (a physics fix) regenerates the file in the same
commit and says why in its message.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
GOLDEN = Path(__file__).resolve().parent / "golden" / "golden_maps.npz"


def _load_script() -> ModuleType:
    script = ROOT / "scripts" / "evidence" / "golden_maps.py"
    spec = importlib.util.spec_from_file_location("golden_maps", script)
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


golden_maps = _load_script()


@pytest.fixture(scope="module")
def stored() -> dict[str, np.ndarray]:
    with np.load(GOLDEN) as data:
        return {k: data[k] for k in data.files}


def test_golden_file_covers_every_case(stored: dict[str, np.ndarray]) -> None:
    names = {key.split("/")[0] for key in stored}
    assert names == set(golden_maps.CASES)
    assert len(names) >= 12


@pytest.mark.parametrize("name", sorted(golden_maps.CASES))
def test_outputs_equal_the_golden_ones(name: str, stored: dict[str, np.ndarray]) -> None:
    current = golden_maps.compute(name)
    mine = {k: v for k, v in stored.items() if k.startswith(f"{name}/")}
    assert golden_maps.differences(mine, current) == []


def test_differences_reports_a_changed_cell(stored: dict[str, np.ndarray]) -> None:
    key = "X_0.25_2/map"
    changed = {key: stored[key].copy()}
    changed[key][3, 4] = (changed[key][3, 4] + 1) % 7
    assert golden_maps.differences({key: stored[key]}, changed) == [
        f"{key}: 1 entries differ, first at (3, 4)"
    ]
