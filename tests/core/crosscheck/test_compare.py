"""crosscheck(): the comparison over cells, the ambiguity detector, processes, convergence."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

import xface_core as xf
from xface_core.crosscheck import DEFAULT_ENGINE, crosscheck
from xface_core.crosscheck.compare import grid_cells, result_json, run_engine

X_FACE = xf.x_face(0.25, 2.0)


def test_unambiguous_cells_agree_with_xface() -> None:
    r = crosscheck(X_FACE, cells=[(0.0, 0.0), (0.95, 1.4)], workers=1)
    assert [xf.Outcome(c).name for c in r.engine] == ["SEATED", "BAD_MATE"]
    assert [xf.Outcome(c).name for c in r.engine_rounded] == ["SEATED", "BAD_MATE"]
    assert [xf.Outcome(c).name for c in r.xface] == ["SEATED", "BAD_MATE"]
    assert not r.ambiguous.any()
    assert (r.agreement, r.outcome_agreement, r.false_seated, r.false_failures) == (1.0, 1.0, 0, 0)
    assert r.disagreements == ()


def test_a_vertex_on_vertex_start_is_ambiguous() -> None:
    # x0 = D/2, theta0 = 0: the notch's rim corner lands on the tip of the male V. Sharp
    # corners seat; 0.002 D of rounding sends the corner down the other flank.
    r = crosscheck(xf.v_face(0.32988, 2.0), cells=[(0.5, 0.0)], workers=1)
    assert r.engine[0] != r.engine_rounded[0]
    assert r.ambiguous.tolist() == [True]
    assert r.n_unambiguous == 0
    assert math.isnan(r.agreement)
    assert r.disagreements == ()  # xface is not judged on an ambiguous cell


def test_a_disagreement_carries_both_final_states() -> None:
    # Judge xface against an engine that cannot seat: its seat tolerance is out of reach.
    strict = DEFAULT_ENGINE.__class__(angle_tol=1e-12, position_tol=1e-12)
    r = crosscheck(X_FACE, cells=[(0.3, 0.2)], settings=strict, workers=1)
    (d,) = r.disagreements
    assert d.kind == "false SEATED"
    assert r.false_seated == 1
    assert d.xface.outcome is xf.Outcome.SEATED
    assert d.engine.outcome is xf.Outcome.BAD_MATE
    assert d.xface.phi_m == pytest.approx(d.engine.phi_m, abs=1e-3)  # same place, other verdict
    out = result_json(r)
    assert out["false_seated"] == 1
    assert out["disagreements"][0]["engine"]["outcome"] == "BAD_MATE"  # type: ignore[index]


def test_the_grid_is_acceptance_map_s_grid() -> None:
    x0, theta0 = grid_cells(5)
    X, T = np.meshgrid(xf.x0_grid(5), xf.theta_grid(5), indexing="ij")
    assert np.array_equal(x0, X.ravel())
    assert np.array_equal(theta0, T.ravel())


def test_processes_give_the_runs_of_one_process() -> None:
    x0, theta0 = grid_cells(3)
    tasks = [(float(x), float(t), DEFAULT_ENGINE) for x, t in zip(x0, theta0, strict=True)]
    seen: list[int] = []
    pooled = run_engine(
        X_FACE, xf.Physics(), tasks, workers=2, progress=lambda d, n, s: seen.append(d)
    )
    inline = run_engine(X_FACE, xf.Physics(), tasks, workers=1)
    assert pooled == inline
    assert seen[-1] == len(tasks)


def test_converged_halves_the_step_until_nothing_changes() -> None:
    coarse = DEFAULT_ENGINE.with_step(4e-4)
    r = crosscheck(X_FACE, cells=[(0.0, 0.0)], settings=coarse, converged=True, workers=1)
    assert r.converged is True
    assert r.step_history == ((2e-4, 0),)
    assert r.settings.step == 2e-4


@pytest.mark.slow
def test_x_face_map_agrees_with_the_engine() -> None:
    # Single contacts along the whole path: the issue saw 99.8-100 % agreement on X-Faces
    # with r_p >= 1, and a false SEATED is the one answer a docking predictor must not give.
    r = crosscheck(X_FACE, grid=11)
    assert r.false_seated == 0
    assert r.agreement >= 0.99
    assert r.n_ambiguous <= 2


def _converged_map(cells: list[tuple[float, float]], converge_by: str) -> Any:
    from xface_core.crosscheck import engine_map

    return engine_map(X_FACE, cells=cells, converged=True, converge_by=converge_by, workers=1)


def _scripted_engine(
    monkeypatch: pytest.MonkeyPatch, seated_at: dict[int, list[bool]]
) -> list[tuple[float, list[float]]]:
    """Replace the engine pass with a script: cell i seats at its k-th step (0: the first,
    1: the first halving, ...) as ``seated_at[i][k]``; returns the (step, cells' x0) of
    every pass, in order."""
    from xface_core.crosscheck import compare
    from xface_core.crosscheck.scene import EngineRun

    passes: list[tuple[float, list[float]]] = []
    first = DEFAULT_ENGINE.step

    def fake(design, physics, x0, theta0, settings, rounding, workers, progress, journal):  # type: ignore[no-untyped-def]
        passes.append((settings.step, [float(x) for x in x0]))
        k = round(math.log2(first / settings.step))
        seats = [seated_at[int(x)][k] for x in x0]
        outcomes = [xf.Outcome.SEATED if s else xf.Outcome.BAD_MATE for s in seats]
        runs = [EngineRun(o, "", 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1, False) for o in outcomes]
        return runs, list(runs)

    monkeypatch.setattr(compare, "_engine_pass", fake)
    return passes


def test_refining_cells_runs_each_halving_on_the_cells_the_last_one_changed(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # Cell 0 never changes, cell 1 changes at the first halving only, cell 2 at the first
    # two: the grid mode runs all three at every halving, the cells mode only the changing.
    script = {0: [True] * 4, 1: [False, True, True, True], 2: [False, True, False, False]}
    cells = [(float(i), 0.0) for i in script]
    passes = _scripted_engine(monkeypatch, script)
    by_cell = _converged_map(cells, "cells")
    assert [len(xs) for _, xs in passes] == [3, 3, 2, 1]
    assert passes[2][1] == [1.0, 2.0]
    assert passes[3][1] == [2.0]
    assert by_cell.step_history == tuple(
        (DEFAULT_ENGINE.step / 2**k, n) for k, n in ((1, 2), (2, 1), (3, 0))
    )
    assert by_cell.converged is True
    assert [r.outcome for r in by_cell.sharp] == [xf.Outcome.SEATED, xf.Outcome.SEATED,
                                                  xf.Outcome.BAD_MATE]  # fmt: skip
    passes.clear()
    by_grid = _converged_map(cells, "grid")
    assert [len(xs) for _, xs in passes] == [3, 3, 3, 3]
    # Here the cells that stopped were already at their final answer: both maps agree.
    assert [r.outcome for r in by_grid.sharp] == [r.outcome for r in by_cell.sharp]
    assert by_cell.converge_by == "cells"
    assert by_grid.converge_by == "grid"


def test_an_unknown_converge_by_is_refused() -> None:
    with pytest.raises(ValueError, match="converge_by must be one of"):
        _converged_map([(0.0, 0.0)], "some")
