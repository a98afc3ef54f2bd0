"""xface_core.cli.bench: the pymunk line of targets.md (timings are never asserted)."""

from __future__ import annotations

import re

import numpy as np
import pytest

from xface_core.cli import bench


def test_the_pymunk_line_has_both_map_times_and_their_ratio() -> None:
    pytest.importorskip("pymunk")
    (line,) = bench._pymunk_lines(True, 1)
    assert line.startswith(
        "| 41 x 41 map, X H/D 0.25 r_p 2: xface (symmetry skip on / off) / pymunk scene "
        "(estimated from the diagonal), one thread each |"
    )
    assert re.search(r"\| \d+ / \d+ ms / \d+\.\d s: \d+x / \d+x \| >= 1000x \|$", line)


@pytest.mark.parametrize("quick", [False, True])
def test_the_pymunk_map_runs_every_cell_once_or_the_diagonal_when_quick(quick: bool) -> None:
    from xface_core import x_face
    from xface_core.maps.grids import theta_grid, x0_grid

    cells: list[tuple[float, float]] = []
    bench._pymunk_map_seconds(
        lambda _d, x0, theta0: cells.append((x0, theta0)), x_face(0.25, 2.0), quick
    )
    x0s, thetas = x0_grid(41).tolist(), theta_grid(41).tolist()
    if quick:
        assert cells == list(zip(x0s, thetas, strict=True))
    else:
        assert len(cells) == 41 * 41
        assert set(cells) == {(x, t) for x in x0s for t in thetas}


def test_without_the_extra_the_line_says_how_to_get_it(monkeypatch: pytest.MonkeyPatch) -> None:
    import builtins

    real_import = builtins.__import__

    def no_crosscheck(name: str, *args: object, **kwargs: object) -> object:
        if name == "crosscheck" or name.endswith(".crosscheck"):
            raise ImportError("no pymunk")
        return real_import(name, *args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(builtins, "__import__", no_crosscheck)
    assert bench._pymunk_lines(True, 1) == [
        "| pymunk scene per 41 x 41 map | not measured: `pip install 'xface[crosscheck]'` | |"
    ]


def _finals(outcome: list[int], phi_m: list[float]) -> bench._Finals:
    n = len(outcome)
    return bench._Finals(
        np.array(outcome, dtype=np.int8),
        np.zeros(n),
        np.array(phi_m),
        np.ones(n),
        np.zeros(n),
    )


def test_nodes_where_the_two_references_differ_are_not_converged() -> None:
    ref = _finals([4, 4, 4, 3, 1], [0.1, 0.1, 0.1, 0.0, np.nan])
    check = _finals([4, 4, 4, 4, 1], [0.1 + 5e-7, 0.1 + 2e-6, 0.1 - 0.3, 0.0, np.nan])
    # Within the agreement; off by 2e-6; off by 0.3 (a jam passed); another outcome; no state.
    assert bench._unconverged_nodes(ref, check).tolist() == [False, True, True, True, False]


def test_the_references_are_rows_of_the_bench_to_the_last_bit() -> None:
    from xface_core.physics import DEFAULT_SETTINGS

    assert bench.tolerances_at(DEFAULT_SETTINGS.rtol) == DEFAULT_SETTINGS
    assert bench.tolerances_at(1e-11) == bench.REFERENCE_SETTINGS
    assert bench.REFERENCE_SETTINGS.event_tol == 1e-15
    assert bench.tolerances_at(1e-10) == bench.REFERENCE_CHECK_SETTINGS


def _rows(mismatches: dict[float, int], ms: dict[float, float]) -> list[dict[str, object]]:
    rows: list[dict[str, object]] = [
        {"rtol": r, "symmetry": True, "mismatch_other": m, "ms_per_map": ms[r]}
        for r, m in mismatches.items()
    ]
    # The row without the symmetry skip (its mismatches are never counted).
    rows.append({"rtol": 1e-8, "symmetry": False, "mismatch_other": 5, "ms_per_map": 0.1})
    return rows


def test_the_loosest_clean_setting_is_picked_by_mismatches_not_by_noisy_times() -> None:
    times = {1e-2: 5.0, 1e-4: 9.0, 1e-6: 7.0, 1e-8: 3.0}  # the tightest measured fastest
    assert bench.loosest_clean_rtol(_rows(dict.fromkeys(times, 0), times)) == 1e-2


def test_a_mismatch_stops_the_loosening_even_if_looser_rows_are_clean_again() -> None:
    times = {1e-2: 5.0, 1e-4: 9.0, 1e-6: 7.0, 1e-8: 3.0}
    rows = _rows({1e-2: 0, 1e-4: 2, 1e-6: 0, 1e-8: 0}, times)
    assert bench.loosest_clean_rtol(rows) == 1e-6


def test_no_setting_is_picked_when_the_tightest_has_mismatches() -> None:
    times = {1e-2: 5.0, 1e-8: 3.0}
    assert bench.loosest_clean_rtol(_rows({1e-2: 0, 1e-8: 1}, times)) is None
