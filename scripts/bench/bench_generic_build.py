"""Time the precompiled engine (built for a generic CPU) against one compiled for this host.

    python scripts/bench/bench_generic_build.py [--build DIR] [--rounds N] [--quick]

The install's precompiled engine (``xface_core/_engine/_compiled``, or ``--build DIR``) is
machine code for a generic CPU of the architecture; a compile on the user's machine would
use every feature of its CPU. Each round runs the same workloads in two fresh processes, one
loading the generic build (an empty numba cache), one loading the host's compile (a numba
cache this script fills first, with the shipped build hidden), alternating which goes first;
each process checks where its engine came from (``runner.engine_state``). Prints the per-call
medians over the rounds and the ratio generic/host per workload and overall (geometric mean).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

#: The child's workloads: 41 x 41 maps of three faces (one thread) and single predictions.
CHILD = textwrap.dedent(
    """
    import json, sys, time
    import xface_core as xf
    from xface_core import runner
    quick = sys.argv[1] == "1"
    state = runner.engine_state()
    runner.warm_up_engine()
    grid = 11 if quick else 41
    designs = {"X 0.25/2": xf.x_face(0.25, 2.0), "V 0.5/1": xf.v_face(0.5, 1.0),
               "S 0.5/1": xf.s_face(0.5, 1.0)}
    times = {}
    for name, d in designs.items():
        xf.acceptance_map(d, grid=grid, threads=1, use_symmetry=False)
        t = time.perf_counter()
        xf.acceptance_map(d, grid=grid, threads=1, use_symmetry=False)
        times[f"map {name} {grid}x{grid}"] = time.perf_counter() - t
    d = designs["X 0.25/2"]
    n = 30 if quick else 300
    t = time.perf_counter()
    for k in range(n):
        xf.predict(d, 0.3 - 0.001 * k, 0.2, path=False)
    times["predict X 0.25/2 (per call)"] = (time.perf_counter() - t) / n
    print(json.dumps({"source": state.source, "times": times}))
    """
)


def _run_child(env: dict[str, str], quick: bool) -> dict[str, object]:
    done = subprocess.run(
        [sys.executable, "-c", CHILD, "1" if quick else "0"],
        env=env, cwd=ROOT, capture_output=True, text=True, check=False,
    )  # fmt: skip
    if done.returncode != 0:
        raise SystemExit(f"bench_generic_build: a child failed:\n{done.stderr[-3000:]}")
    result: dict[str, object] = json.loads(done.stdout.strip().splitlines()[-1])
    return result


def _env(shipped: Path, numba_cache: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
    env["XFACE_PRECOMPILED_DIR"] = str(shipped)
    env["NUMBA_CACHE_DIR"] = str(numba_cache)
    return env


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    default_build = ROOT / "xface_core" / "_engine" / "_compiled"
    parser.add_argument("--build", type=Path, default=default_build, help="the generic build")
    parser.add_argument("--rounds", type=int, default=7, help="rounds (default 7)")
    parser.add_argument("--quick", action="store_true", help="11 x 11 maps, 30 predictions")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="xface-generic-") as scratch:
        generic = _env(args.build, Path(scratch) / "empty-cache")
        host = _env(Path(scratch) / "no-build", Path(scratch) / "host-cache")
        print("bench_generic_build: compiling the engine for this host first", flush=True)
        _run_child(host, quick=True)
        samples: dict[str, dict[str, list[float]]] = {"generic": {}, "host": {}}
        for round_ in range(args.rounds):
            order = [("generic", generic), ("host", host)]
            for label, env in order if round_ % 2 == 0 else order[::-1]:
                result = _run_child(env, args.quick)
                want = "precompiled" if label == "generic" else "cached"
                if result["source"] != want:
                    raise SystemExit(f"bench_generic_build: {label} ran {result['source']!r}")
                times = result["times"]
                assert isinstance(times, dict)
                for name, seconds in times.items():
                    samples[label].setdefault(name, []).append(float(seconds))
    print("| workload | generic (median) | host (median) | generic/host |")
    print("| --- | ---: | ---: | ---: |")
    ratios = []
    for name in samples["generic"]:
        g = statistics.median(samples["generic"][name])
        h = statistics.median(samples["host"][name])
        ratios.append(g / h)
        print(f"| {name} | {g * 1e3:.3f} ms | {h * 1e3:.3f} ms | {g / h:.3f} |")
    geo = math.exp(statistics.fmean(math.log(r) for r in ratios))
    print(f"| every workload (geometric mean) | | | {geo:.3f} |")
    print(f"{args.rounds} rounds, each process a fresh interpreter; load {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
