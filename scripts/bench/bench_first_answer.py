#!/usr/bin/env python3
"""First answer: how long one ``xface predict`` takes from a fresh interpreter, as a user
or a planner calling the CLI meets it (the engine precompiled or cached, nothing compiled).

    python scripts/bench/bench_first_answer.py                  # 9 repeats, about a minute
    python scripts/bench/bench_first_answer.py --repeats 15 --out first_answer.md

Issue 37 asks ``xface predict`` at the largest accepted design (H/D = r_p = 50) to answer
within a second. Each repeat runs, one after the other, in fresh interpreters:

* ``lean``: ``xface predict ...`` as installed;
* ``refreshed``: the same command after ``cpu_target.target_context.refresh()``, what
  numba's own cache loader does before loading a kernel (every lowering and typing registry
  imported and installed). ``ShippedFunctionCache.load_overload`` skips it; this variant
  prices the skip in the same run;
* ``import``: ``import xface_core`` alone (the floor under any command).

for the largest design and a small one (X 0.25/2). Prints a Markdown table of the wall
seconds (median, min, max) and the ratio lean / refreshed of the medians; ``--out FILE``
writes it too. Exit 1 if the engine would compile (nothing to measure then: run
``make precompile``) or a command fails. Uses the standard library only.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

#: (name, xface predict arguments)
CASES = (
    ("largest (X H/D 50, r_p 50)", "--face X --h-over-d 50 --rp 50 --x0 0.5 --theta0 0.3"),
    ("small (X H/D 0.25, r_p 2)", "--face X --h-over-d 0.25 --rp 2 --x0 0.5 --theta0 0.3"),
)

_CLI = "import sys; from xface_core.cli import main; sys.exit(main(sys.argv[1:]))"
_REFRESHED = (
    "from numba.core.registry import cpu_target; cpu_target.target_context.refresh(); " + _CLI
)
_STATE = "from xface_core import runner; print(runner.engine_state().describe())"


def _time(argv: list[str]) -> float:
    start = time.perf_counter()
    done = subprocess.run(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, check=False)
    elapsed = time.perf_counter() - start
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(argv)} failed: {done.stderr.decode()[-500:]}")
    return elapsed


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=9, help="fresh processes per variant")
    parser.add_argument("--out", type=Path, help="also write the report here")
    args = parser.parse_args()
    if args.repeats < 1:
        parser.error("--repeats must be at least 1")
    py = sys.executable
    state = subprocess.run([py, "-c", _STATE], capture_output=True, text=True, check=False)
    described = state.stdout.strip()
    if state.returncode != 0 or not described.startswith("ready"):
        print(f"bench_first_answer: the engine is not ready ({described or state.stderr[-300:]})")
        return 1
    times: dict[tuple[str, str], list[float]] = {}
    try:
        for _ in range(args.repeats):
            times.setdefault(("", "import"), []).append(_time([py, "-c", "import xface_core"]))
            for name, cli in CASES:
                for variant, code in (("lean", _CLI), ("refreshed", _REFRESHED)):
                    argv = [py, "-c", code, "predict", *cli.split()]
                    times.setdefault((name, variant), []).append(_time(argv))
    except RuntimeError as exc:
        print(f"bench_first_answer: {exc}")
        return 1

    def cell(key: tuple[str, str]) -> str:
        t = times[key]
        return f"{statistics.median(t):.3f} ({min(t):.3f}-{max(t):.3f})"

    heading = (
        f"First answer of `xface predict`, wall seconds over {args.repeats} fresh processes "
        f"each: median (min-max). Engine: {described}. Load average at the end: "
        f"{os.getloadavg()[0]:.2f}."
    )
    lines = [
        heading,
        "",
        "| design | lean (as installed) | refreshed (numba's loader) | lean / refreshed |",
        "|---|---:|---:|---:|",
    ]
    for name, _ in CASES:
        ratio = statistics.median(times[(name, "lean")]) / statistics.median(
            times[(name, "refreshed")]
        )
        lines.append(
            f"| {name} | {cell((name, 'lean'))} | {cell((name, 'refreshed'))} | {ratio:.3f} |"
        )
    lines += ["", f"`import xface_core` alone: {cell(('', 'import'))} s."]
    report = "\n".join(lines) + "\n"
    print(report, end="")
    if args.out is not None:
        try:
            args.out.write_text(report)
        except OSError as exc:
            print(f"bench_first_answer: cannot write {args.out}: {exc.strerror}")
            return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
