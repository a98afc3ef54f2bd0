"""Build the precompiled engine that ships with an install, and check that it loads.

``python -m xface_core.precompile DIR`` compiles every entry point of the engine
(:func:`xface_core.runner.warm_up_engine`) for a generic CPU of this architecture and writes
numba's cache files and a manifest into DIR (:mod:`xface_core._engine.precompiled`). The
wheel's build runs it into the built package (``setup.py``), ``make setup`` into the source
tree. Then it checks, in a fresh process with an empty numba cache, that the engine loads
from DIR with nothing compiled; exit 1 if not.

The compile runs in a child process of its own: numba reads ``NUMBA_CPU_NAME`` when it is
imported, and the child's numba cache is a temporary folder, so nothing of the build's
machine (its CPU, its user cache) goes into the files and no earlier build is reused.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path

from xface_core._engine.precompiled import MANIFEST_NAME, SHIPPED_DIR_ENV, write_manifest

__all__ = ["GENERIC_CPU", "build", "check", "main"]

#: The environment that makes numba compile for a generic CPU of this architecture (what the
#: shipped build is; set for the build's child process).
GENERIC_CPU = {"NUMBA_CPU_NAME": "generic", "NUMBA_CPU_FEATURES": ""}


def _child_env(numba_cache: Path, shipped: Path, extra: dict[str, str]) -> dict[str, str]:
    env = {key: value for key, value in os.environ.items() if not key.startswith("NUMBA_")}
    env.update(extra)
    env["NUMBA_CACHE_DIR"] = str(numba_cache)
    env[SHIPPED_DIR_ENV] = str(shipped)
    # The package this module belongs to, first: a build runs from its build folder.
    root = str(Path(__file__).resolve().parents[1])
    env["PYTHONPATH"] = os.pathsep.join([root, *filter(None, [env.get("PYTHONPATH")])])
    return env


def _run_child(mode: str, numba_cache: Path, shipped: Path, extra: dict[str, str]) -> dict:  # type: ignore[type-arg]
    """Run this module in ``mode`` in a child process; its JSON report."""
    done = subprocess.run(
        [sys.executable, "-m", "xface_core.precompile", f"--{mode}-child", str(shipped)],
        env=_child_env(numba_cache, shipped, extra),
        capture_output=True,
        text=True,
        check=False,
    )
    if done.returncode != 0:
        raise RuntimeError(f"the {mode} step failed:\n{done.stderr.strip()}")
    report: dict = json.loads(done.stdout.strip().splitlines()[-1])  # type: ignore[type-arg]
    return report


def build(out_dir: Path) -> dict:  # type: ignore[type-arg]
    """Compile the engine for a generic CPU into ``out_dir`` (replacing what is there); the
    child's report: CPU seconds of the compile, numba's codegen tuple, files written."""
    out_dir.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="xface-build-") as scratch:
        numba_cache = Path(scratch) / "numba"
        empty = Path(scratch) / "no-shipped-engine"  # no earlier build is reused
        report = _run_child("build", numba_cache, empty, GENERIC_CPU)
        for old in [*out_dir.glob("*.nbi"), *out_dir.glob("*.nbc"), out_dir / MANIFEST_NAME]:
            old.unlink(missing_ok=True)
        folders = [p for p in numba_cache.iterdir() if p.is_dir()]
        files = [f for folder in folders for f in folder.iterdir() if f.suffix in (".nbi", ".nbc")]
        for f in files:
            shutil.copy2(f, out_dir / f.name)
        write_manifest(
            out_dir, magic=tuple(report["magic"]), compile_cpu_s=float(report["compile_cpu_s"])
        )
        report["files"] = len(files)
    return report


def check(out_dir: Path) -> dict:  # type: ignore[type-arg]
    """Warm the engine up in a fresh process with an empty numba cache and the build in
    ``out_dir``: its report says what was compiled (nothing, when the build serves)."""
    with tempfile.TemporaryDirectory(prefix="xface-check-") as scratch:
        report = _run_child("check", Path(scratch) / "numba", out_dir, {})
        written = list((Path(scratch) / "numba").rglob("*.nbi"))
        report["compiled_files"] = len(written)
    return report


def _child(mode: str) -> None:
    """In the child: warm the engine up and print a JSON report on the last line."""
    cpu0 = time.process_time()
    from xface_core import _engine, runner

    state_before = runner.engine_state()
    runner.warm_up_engine()
    cpu_s = time.process_time() - cpu0
    codegen = _engine.ENTRY_POINTS[0].targetctx.codegen()
    report = {
        "mode": mode,
        "compile_cpu_s": cpu_s,
        "magic": list(codegen.magic_tuple()),
        "state_before": state_before.describe(),
        "why_not_precompiled": state_before.why_not_precompiled,
    }
    print(json.dumps(report))


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m xface_core.precompile DIR``: build, then check; 0 when the build loads."""
    parser = argparse.ArgumentParser(prog="python -m xface_core.precompile", description=__doc__)
    parser.add_argument("out_dir", type=Path, help="folder for the precompiled engine")
    parser.add_argument("--no-check", action="store_true", help="skip the loading check")
    parser.add_argument("--build-child", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--check-child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.build_child or args.check_child:
        _child("build" if args.build_child else "check")
        return 0
    wall0 = time.perf_counter()
    report = build(args.out_dir)
    print(
        f"xface: precompiled the engine into {args.out_dir} ({report['files']} files, "
        f"{report['compile_cpu_s']:.0f} s of CPU, {time.perf_counter() - wall0:.0f} s)",
        flush=True,
    )
    if args.no_check:
        return 0
    result = check(args.out_dir)
    if result["compiled_files"] or result["state_before"] != "ready (precompiled)":
        print(
            f"xface: the precompiled engine does not load: {result['state_before']}; "
            f"{result['why_not_precompiled'] or ''} ({result['compiled_files']} kernels compiled)",
            file=sys.stderr,
        )
        return 1
    print(f"xface: checked: it loads in {result['compile_cpu_s']:.1f} s of CPU, nothing compiled")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
