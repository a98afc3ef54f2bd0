"""scripts/bench/profile_kernel.py: a perf map of the compiled engine, and the shares of a profile.

The profile itself needs ``perf`` and half a minute; the tests check the map's form and the
report's arithmetic on a sample of ``perf report`` output.
"""

from __future__ import annotations

import importlib
import sys
from pathlib import Path

import numpy as np
import pytest

import xface_core as xf
import xface_core._engine as engine

ROOT = Path(__file__).resolve().parents[3]


sys.path.insert(0, str(ROOT / "scripts" / "bench"))
profile = importlib.import_module("profile_kernel")

SAMPLE = """\
# Samples: 1K of event 'cpu-clock'
#
    50.00%  python   [.] _PyEval_EvalFrameDefault   -      -
    30.00%  [JIT] tid 7   [.] scan._contact_events   -      -
    10.00%  libm.so.6     [.] __sincos_fma           -      -
     5.00%  [JIT] tid 7   [.] pairs.eval_pair        -      -
     5.00%  [JIT] tid 8   [.] scan._contact_events   -      -
"""


def test_shares_count_engine_code_and_libm_only() -> None:
    got = profile.shares(SAMPLE)
    assert list(got) == ["scan._contact_events", "__sincos_fma", "pairs.eval_pair"]
    assert got["scan._contact_events"] == pytest.approx(70.0)
    assert got["__sincos_fma"] == pytest.approx(20.0)
    assert sum(got.values()) == pytest.approx(100.0)


def test_perf_map_lists_the_batch_entry_with_its_address(tmp_path: Path) -> None:
    xf.predict_batch(xf.v_face(0.5, 1.0), np.zeros(2), np.zeros(2), threads=1)
    path = tmp_path / "perf-1.map"
    n = profile.write_perf_map(engine.simulate_many, engine, path)
    rows = [line.split() for line in path.read_text("utf-8").splitlines()]
    assert n == len(rows) >= 1
    assert "simulate.simulate_many" in [name for _, _, name in rows]
    for address, size, _ in rows:
        assert int(address, 16) > 0
        assert int(size, 16) > 0


def test_the_profiled_process_compiles_past_numba_s_cache_and_the_shipped_engine(
    tmp_path: Path,
) -> None:
    env = profile.compile_afresh_env({"PATH": "/bin"}, tmp_path, apart=False)
    assert env["NUMBA_CACHE_DIR"] == str(tmp_path)
    shipped = Path(env["XFACE_PRECOMPILED_DIR"])
    assert shipped.is_dir()
    assert not any(shipped.iterdir())
    assert "NUMBA_DEBUGINFO" not in env
    assert env["PATH"] == "/bin"


def test_apart_compiles_with_debug_info_so_no_engine_function_is_inlined(tmp_path: Path) -> None:
    assert profile.compile_afresh_env({}, tmp_path, apart=True)["NUMBA_DEBUGINFO"] == "1"


def test_a_missing_profile_is_refused_without_a_traceback(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert profile.main(["--report", str(tmp_path / "none.data")]) == 2
    assert "no perf data" in capsys.readouterr().err


def test_poses_are_read_in_d_and_scaled_to_the_design_s_width(tmp_path: Path) -> None:
    path = tmp_path / "poses.npz"
    np.savez(path, x0=np.array([0.1, -0.2]), theta0=np.array([0.3, 0.0]))
    x, t = profile.poses_from(path, 2.0)
    assert x.tolist() == [0.2, -0.4]
    assert t.tolist() == [0.3, 0.0]


def test_a_poses_file_without_theta0_is_refused_with_what_it_lacks(tmp_path: Path) -> None:
    path = tmp_path / "poses.npz"
    np.savez(path, x0=np.array([0.1]))
    with pytest.raises(SystemExit, match="no array theta0"):
        profile.poses_from(path, 1.0)


NM_SAMPLE = """\
0000000000000490 000000000000001c r .const.<numba.core.cpu.CPUContext>
0000000000001000 0000000000001cc2 W _ZN10xface_core7_engine4scan11_gap_boundsB4v219
0000000000003000 0000000000004e2e W _ZN10xface_core7_engine4scan15_contact_eventsB4v164
0000000000009000 000000000000256c T _ZN10xface_core7_engine8simulate13simulate_manyB3v10
                 U sincos
"""


def test_function_sizes_are_read_from_nm_for_text_and_weak_symbols_only() -> None:
    sizes = profile.function_sizes(NM_SAMPLE)
    assert sizes == {
        "_ZN10xface_core7_engine4scan11_gap_boundsB4v219": 0x1CC2,
        "_ZN10xface_core7_engine4scan15_contact_eventsB4v164": 0x4E2E,
        "_ZN10xface_core7_engine8simulate13simulate_manyB3v10": 0x256C,
    }
