"""scripts/bench/bench_atlas.py counts what the margins send to the engine (it once counted a name
the margins no longer called, and read 0 without an error)."""

from __future__ import annotations

import importlib.util
import math
import sys
from collections.abc import Callable
from pathlib import Path
from types import ModuleType

import xface_core as xf
from xface_core.atlas.build import build_atlas

SCRIPT = Path(__file__).resolve().parents[3] / "scripts" / "bench" / "bench_atlas.py"


def _script() -> ModuleType:
    spec = importlib.util.spec_from_file_location("bench_atlas", SCRIPT)
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules["bench_atlas"] = module
    spec.loader.exec_module(module)
    return module


def _counted(query: Callable[[], object]) -> tuple[int, int]:
    """(poses, calls) that ``query`` sent to the engine, by the script's counter."""
    counter = _script().SimulationCounter()
    counter.install()
    counter.take()
    query()
    counted: tuple[int, int] = counter.take()
    assert counter.take() == (0, 0)
    return counted


def test_the_counter_sees_the_simulations_of_margins_from_the_atlas() -> None:
    design = xf.v_face(0.5, 1.0)
    atlas = build_atlas(
        design, lateral_step=1 / 32, angle_step=math.pi / 128, angle_range=math.pi / 2
    )
    outcome = xf.predict(design, 0.1, 0.2, path=False).outcome
    poses, calls = _counted(lambda: xf.margins_from_atlas(atlas, 0.1, 0.2, outcome))
    assert calls > 0
    assert poses >= calls


def test_the_counter_sees_the_simulations_of_the_exact_margin_search() -> None:
    design = xf.v_face(0.5, 1.0)
    outcome = xf.predict(design, 0.1, 0.2, path=False).outcome
    poses, calls = _counted(lambda: xf.outcome_margins(design, 0.1, 0.2, outcome))
    assert calls > 0
    assert poses >= calls
