"""The precompiled engine: built for a generic CPU, loaded with nothing compiled, never used
when it does not match, and covering every entry point the library calls.

The build itself (``python -m xface_core.precompile``) takes a minute or two of CPU; the
suite builds one per session (into a temporary folder) only when the install has none.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path
from typing import Any

import numba
import pytest

from xface_core._engine import precompiled
from xface_core._engine._stale import source_digest

ROOT = Path(__file__).resolve().parents[3]


def _env(shipped: Path, numba_cache: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
    env[precompiled.SHIPPED_DIR_ENV] = str(shipped)
    env["NUMBA_CACHE_DIR"] = str(numba_cache)
    return env


def _run(code: str, shipped: Path, numba_cache: Path, *argv: str) -> dict[str, Any]:
    """Run ``code`` (with ``argv`` in sys.argv[1:]) in a fresh interpreter with the build in
    ``shipped`` and an empty numba cache; the JSON it prints last."""
    done = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code), *argv],
        env=_env(shipped, numba_cache),
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    result: dict[str, Any] = json.loads(done.stdout.strip().splitlines()[-1])
    return result


@pytest.fixture(scope="session")
def shipped_build(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The install's precompiled engine, or (none, or of other sources) one built now."""
    if (
        precompiled.manifest_problem(
            precompiled.read_manifest(precompiled.SHIPPED_DIR), precompiled.host_triple()
        )
        is None
    ):
        return precompiled.SHIPPED_DIR
    out = tmp_path_factory.mktemp("precompiled")
    subprocess.run(
        [sys.executable, "-m", "xface_core.precompile", str(out), "--no-check"],
        cwd=ROOT,
        check=True,
        capture_output=True,
    )
    return out


def _copy(build: Path, to: Path) -> Path:
    shutil.copytree(build, to)
    return to


# ---- the manifest ------------------------------------------------------------------------


def _manifest(**changes: Any) -> dict[str, Any]:
    manifest: dict[str, Any] = {
        "format": precompiled.MANIFEST_FORMAT,
        "numba": numba.__version__,
        "python": f"{sys.version_info[0]}.{sys.version_info[1]}",
        "magic": [precompiled.host_triple(), "generic", ""],
        "sources": source_digest(),
        "compile_cpu_s": 60.0,
    }
    manifest.update(changes)
    return manifest


def test_a_matching_manifest_serves() -> None:
    assert precompiled.manifest_problem(_manifest(), precompiled.host_triple()) is None


@pytest.mark.parametrize(
    ("change", "said"),
    [
        ({"numba": "0.1.0"}, "numba 0.1.0"),
        ({"python": "3.99"}, "Python 3.99"),
        ({"sources": "0" * 64}, "other engine sources"),
        ({"magic": ["riscv64-unknown-linux-gnu", "generic", ""]}, "another architecture"),
        ({"format": 99}, "another layout"),
    ],
)
def test_a_build_of_anything_else_does_not_serve(change: dict[str, Any], said: str) -> None:
    problem = precompiled.manifest_problem(_manifest(**change), precompiled.host_triple())
    assert problem is not None
    assert said in problem


def test_no_manifest_does_not_serve(tmp_path: Path) -> None:
    assert precompiled.read_manifest(tmp_path) is None
    assert "no precompiled engine" in str(precompiled.manifest_problem(None, "x86_64"))


def test_an_unreadable_manifest_is_none(tmp_path: Path) -> None:
    (tmp_path / precompiled.MANIFEST_NAME).write_text("{not json")
    assert precompiled.read_manifest(tmp_path) is None


def test_the_compile_estimate_is_the_builds_own_measure() -> None:
    assert precompiled.compile_estimate_s(_manifest(compile_cpu_s=81.5)) == 81.5
    assert precompiled.compile_estimate_s(None) == precompiled.TYPICAL_COMPILE_CPU_S


def test_the_install_carries_a_precompiled_engine_that_serves() -> None:
    """``make setup`` (and CI's fresh clone) builds it; after an edit of xface_core/_engine
    it no longer matches until ``make precompile`` builds it again."""
    manifest = precompiled.read_manifest(precompiled.SHIPPED_DIR)
    problem = precompiled.manifest_problem(manifest, precompiled.host_triple())
    assert problem is None, f"{problem}: run make precompile"


# ---- a fresh process with the build ------------------------------------------------------

_WARM_UP = """
    import json
    from xface_core import _engine, runner
    before = runner.engine_state()
    runner.warm_up_engine()
    after = runner.engine_state()
    print(json.dumps({"before": before.describe(), "source": before.source,
                      "why": before.why_not_precompiled, "after": after.describe()}))
"""


def test_the_build_loads_with_nothing_compiled(shipped_build: Path, tmp_path: Path) -> None:
    numba_cache = tmp_path / "numba"
    result = _run(_WARM_UP, shipped_build, numba_cache)
    assert result["before"] == "ready (precompiled)"
    assert not list(numba_cache.rglob("*.nbi"))  # numba wrote nothing: nothing compiled


def test_a_build_of_other_sources_is_not_used(shipped_build: Path, tmp_path: Path) -> None:
    build = _copy(shipped_build, tmp_path / "build")
    manifest = json.loads((build / precompiled.MANIFEST_NAME).read_text())
    manifest["sources"] = "0" * 64
    (build / precompiled.MANIFEST_NAME).write_text(json.dumps(manifest))
    code = """
        import json
        from xface_core import runner
        s = runner.engine_state()
        print(json.dumps({"ready": s.ready, "source": s.source, "why": s.why_not_precompiled}))
    """
    result = _run(code, build, tmp_path / "numba")
    assert result == {
        "ready": False,
        "source": "compiles",
        "why": "built from other engine sources",
    }


def test_a_damaged_build_file_falls_back_to_compiling(shipped_build: Path, tmp_path: Path) -> None:
    """A truncated data file of one entry point: that entry compiles (and is cached by numba)
    instead of failing; the others still load."""
    build = _copy(shipped_build, tmp_path / "build")
    damaged = sorted(build.glob("simulate.lowest_reach-*.nbc"))
    assert damaged
    for path in damaged:
        path.write_bytes(path.read_bytes()[:100])
    code = """
        import json
        from xface_core import _engine
        r = _engine.lowest_reach.py_func  # the plain function, for the expected value
        import numpy as np
        v = np.array([[0.5, -1.0], [-0.5, 2.0]])
        got = _engine.lowest_reach(v, 0.3)
        print(json.dumps({"equal": bool(got == r(v, 0.3)),
                          "misses": sum(_engine.lowest_reach.stats.cache_misses.values())}))
    """
    numba_cache = tmp_path / "numba"
    result = _run(code, build, numba_cache)
    assert result == {"equal": True, "misses": 1}
    assert list(numba_cache.rglob("simulate.lowest_reach-*.nbi"))  # compiled and cached


_WIDE_USE = """
    import json
    import numpy as np
    import xface_core as xf
    from xface_core import _engine, runner
    runner.warm_up_engine()
    before = {k.py_func.__qualname__: len(k.overloads) for k in _engine.KERNELS}
    x = xf.x_face(0.25, 1.0, width=0.05)
    v = xf.v_face(0.5, 2.0)
    sq = [(-0.5, -1.0), (0.5, -1.0), (0.5, 0.5), (-0.5, 0.5)]
    custom = xf.custom_face([sq], [sq], mated_distance=1.0)
    rough = xf.Physics(damping_ratio=2.0, friction=0.2)
    p = xf.predict(x, 0.01, 0.2, margins=True)
    p.contact_points(3)
    xf.predict(v, 0.1, -0.3, physics=rough, path=False)
    xf.predict(custom, 0.1, 0.1)
    xf.predict(x, 0.01, 0.2, y_start=0.2)
    xf.predict_batch(v, np.linspace(-1, 1, 300).reshape(20, 15), 0.1, threads=2)
    xf.predict_batch(v, [0.0, 0.1], [0.1, 0.2], y_start=[3.0, 3.0], threads=1)
    xf.acceptance_map(x, grid=11, threads=2)
    cov = [[0.002**2, 0.0], [0.0, 0.05**2]]
    xf.seat_probability(x, 0.015, 0.2, cov)
    after = {k.py_func.__qualname__: len(k.overloads) for k in _engine.KERNELS}
    grown = {k: after[k] - before[k] for k in after if after[k] != before[k]}
    print(json.dumps({"compiled": grown}))
"""


def test_the_warm_up_covers_what_the_library_calls(shipped_build: Path, tmp_path: Path) -> None:
    """After :func:`warm_up_engine` (what the build compiles), predictions with margins and
    contact points, batches split over threads, maps, custom faces, friction and seat
    probabilities compile nothing more: a fresh install answers them all warm."""
    result = _run(_WIDE_USE, shipped_build, tmp_path / "numba")
    assert result == {"compiled": {}}


_ANSWERS = """
    import json, sys
    import numpy as np
    if sys.argv[1] == "refreshed":
        from numba.core.registry import cpu_target
        cpu_target.target_context.refresh()  # what numba's own load_overload does first
    import xface_core as xf
    x = xf.x_face(0.25, 2.0)
    p = xf.predict(x, 0.3, 0.2, margins=True)
    rough = xf.Physics(damping_ratio=2.0, friction=0.2)
    q = xf.predict(xf.v_face(0.5, 1.0), 0.1, -0.3, physics=rough)
    b = xf.predict_batch(xf.s_face(0.5, 1.0), np.linspace(-1, 1, 41), 0.3, threads=1)
    print(json.dumps({
        "registries": "numba.np.linalg" in sys.modules,
        "p": [int(p.outcome), p.phi_b, p.phi_m, p.margins.lateral_minus,
              p.margins.angle_plus, p.path.descent.tolist()],
        "q": [int(q.outcome), q.phi_b, q.phi_m, q.path.phi_m.tolist()],
        "b": [np.asarray(b.outcome).tolist(), np.asarray(b.phi_m).tolist()],
    }))
"""


def test_a_cached_kernel_loads_without_numbas_compile_registries(
    shipped_build: Path, tmp_path: Path
) -> None:
    """Loading the engine brings up numba's runtime only, not the registries a compile
    needs (ShippedFunctionCache.load_overload), and its answers are those of a process whose
    contexts were refreshed first, to the last bit."""

    def answers(how: str) -> dict[str, Any]:
        return _run(_ANSWERS, shipped_build, tmp_path / how, how)

    lean, refreshed = answers("lean"), answers("refreshed")
    assert lean.pop("registries") is False
    assert refreshed.pop("registries") is True
    assert lean == refreshed
