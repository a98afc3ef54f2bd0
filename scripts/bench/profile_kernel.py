#!/usr/bin/env python3
"""Where the compiled kernel spends its time: a ``perf`` profile with the engine's names.

    perf record -F 2000 -o /tmp/kernel.data \\
        .venv/bin/python scripts/bench/profile_kernel.py --face S --h-over-d 0.5 --r-p 1 \\
        --seconds 30
    .venv/bin/python scripts/bench/profile_kernel.py --report /tmp/kernel.data
    # other poses than a map's, e.g. a margin search's confirmations:
    perf record -F 2000 -o /tmp/kernel.data .venv/bin/python scripts/bench/profile_kernel.py \
        --face X --h-over-d 0.25 --r-p 1 --poses poses.npz --seconds 25

``perf`` sees numba's machine code as anonymous memory. The first form compiles the engine
afresh (into a temporary numba cache: a kernel loaded from the cache knows only its entry
points), writes ``/tmp/perf-<pid>.map`` with the address of every engine function in the
batch entry's code (with its size from the object code), then runs 41 x 41 maps of
the design on one thread for ``--seconds``. The second form prints the share of each engine
function and libm routine among the samples in engine code and libm (the compilation, the
interpreter and numpy are left out), largest first.

Functions LLVM inlined into their caller count as the caller (most of the engine: by default
the map names the batch entry and little else); ``--apart`` keeps them apart, at the cost of a
call each. libm's ``sincos`` and ``hypot`` are listed on their own.
"""

from __future__ import annotations

import argparse
import importlib
import os
import pkgutil
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any


def write_perf_map(entry: object, package: object, path: Path) -> int:
    """A perf map (``address size name`` per line, hex) at ``path`` of the engine functions
    linked into ``entry``'s code; the number of functions found.

    Where ``entry`` was compiled in this process, its object code gives every function
    linked into it with its true size (``nm -S``: the functions LLVM did not inline, numba's
    weak copies of the callees). Loaded from a cache it has none: then each function runs to
    the next one's address, which can credit a function with code that is not its own, and
    other libraries' copies of a function (not the code the entry runs) are listed too.
    """
    from numba.core.registry import CPUDispatcher

    names: dict[str, str] = {}
    for info in pkgutil.iter_modules(package.__path__):  # type: ignore[attr-defined]
        module = importlib.import_module(f"{package.__name__}.{info.name}")  # type: ignore[attr-defined]
        for value in vars(module).values():
            if isinstance(value, CPUDispatcher):
                for cres in value.overloads.values():
                    fndesc = cres.fndesc
                    names[fndesc.mangled_name] = (
                        f"{fndesc.modname.rsplit('.', 1)[-1]}.{fndesc.qualname}"
                    )
    library = next(iter(entry.overloads.values())).library  # type: ignore[attr-defined]
    sizes = object_sizes(library)
    found = []
    for mangled, name in names.items():
        if sizes is not None and mangled not in sizes:
            continue  # not linked into the entry's code (its own library's copy is not run)
        try:
            address = library.get_pointer_to_function(mangled)
        except Exception:  # a function that was never linked in: not in the profile
            continue
        if address:
            found.append((address, name, None if sizes is None else sizes[mangled]))
    found.sort()
    if not found:
        return 0
    with open(path, "w", encoding="utf-8") as out:
        ends = [a for a, _, _ in found[1:]] + [found[-1][0] + 65536]
        for (address, name, size), end in zip(found, ends, strict=True):
            span = min(end - address, 1 << 20) if size is None else size
            out.write(f"{address:x} {span:x} {name}\n")
    return len(found)


def object_sizes(library: Any) -> dict[str, int] | None:
    """The size (bytes) of every function defined in a numba code library's object code,
    by its symbol; None when the library holds no object code (loaded from a cache) or
    binutils' ``nm`` is missing."""
    if shutil.which("nm") is None:
        return None
    try:
        obj = library._get_compiled_object()
    except Exception:
        return None
    with tempfile.NamedTemporaryFile(suffix=".o") as f:
        f.write(obj)
        f.flush()
        listing = subprocess.run(
            ["nm", "-S", "--defined-only", f.name], capture_output=True, text=True, check=True
        ).stdout
    return function_sizes(listing)


def function_sizes(nm_listing: str) -> dict[str, int]:
    """Function symbols and their sizes from ``nm -S`` output (text and weak symbols;
    data and symbols without a size are left out)."""
    out = {}
    for line in nm_listing.splitlines():
        fields = line.split()
        if len(fields) == 4 and fields[2] in ("T", "t", "W", "w"):
            out[fields[3]] = int(fields[1], 16)
    return out


def compile_afresh_env(environ: dict[str, str], cache: Path, apart: bool) -> dict[str, str]:
    """``environ`` for a process that compiles every engine function itself: numba's cache in
    the empty folder ``cache``, and an empty folder (made in it) in place of the precompiled
    engine. A kernel loaded from numba's cache or from the shipped build
    (:mod:`xface_core._engine.precompiled`) knows only its entry points: the map then named
    3 functions. ``apart``: compiled with debug info, which numba marks noinline."""
    shipped = cache / "no-precompiled-engine"
    shipped.mkdir(exist_ok=True)
    env = dict(environ, NUMBA_CACHE_DIR=str(cache), XFACE_PRECOMPILED_DIR=str(shipped))
    if apart:
        env["NUMBA_DEBUGINFO"] = "1"
    return env


def _run(args: argparse.Namespace, argv: list[str]) -> int:
    if "NUMBA_CACHE_DIR" not in os.environ:
        # Restart, so that every engine function is compiled here.
        with tempfile.TemporaryDirectory(prefix="xface-profile-") as cache:
            env = compile_afresh_env(dict(os.environ), Path(cache), args.apart)
            return subprocess.call([sys.executable, __file__, *argv], env=env)
    import numpy as np

    import xface_core as xf
    import xface_core._engine as engine
    from xface_core.maps.grids import theta_grid, x0_grid

    makers = {"X": xf.x_face, "V": xf.v_face, "S": xf.s_face}
    design = makers[args.face](args.h_over_d, args.r_p)
    if args.poses is None:
        x, t = np.meshgrid(x0_grid(41), theta_grid(41), indexing="ij")
    else:
        x, t = poses_from(args.poses, design.width)
    xf.predict_batch(design, x, t, threads=1)  # compiles
    n = write_perf_map(engine.simulate_many, engine, Path(f"/tmp/perf-{os.getpid()}.map"))
    print(f"perf map: {n} engine functions", file=sys.stderr)
    maps = 0
    t0 = time.perf_counter()
    while time.perf_counter() - t0 < args.seconds:
        xf.predict_batch(design, x, t, threads=1)
        maps += 1
    print(f"{maps} batches of {x.size} poses in {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    return 0


def poses_from(path: Path, width: float) -> tuple[Any, Any]:
    """The poses of an ``.npz`` with arrays ``x0`` (D) and ``theta0`` (rad) of one shape, as
    (x0 in the design's length unit, theta0) for ``predict_batch``."""
    import numpy as np

    with np.load(path) as poses:
        missing = {"x0", "theta0"} - set(poses.files)
        if missing:
            raise SystemExit(
                f"{path}: no array {', '.join(sorted(missing))} (x0 in D, theta0 in rad)"
            )
        x0, theta0 = np.asarray(poses["x0"], dtype=float), np.asarray(poses["theta0"], dtype=float)
    if x0.shape != theta0.shape:
        raise SystemExit(f"{path}: x0 {x0.shape} and theta0 {theta0.shape} differ in shape")
    return x0 * width, theta0


def shares(perf_report: str) -> dict[str, float]:
    """Each engine function's and libm routine's share (%) of the samples in engine code and
    libm, from ``perf report --sort dso,symbol --stdio`` output (other lines are ignored)."""
    found: dict[str, float] = {}
    for line in perf_report.splitlines():
        if line.startswith("#") or "%" not in line or "[.]" not in line:
            continue
        if "[JIT]" not in line and "libm" not in line:
            continue
        name = line.split("[.]", 1)[1].split()[0]
        found[name] = found.get(name, 0.0) + float(line.split("%", 1)[0])
    total = sum(found.values())
    return {k: 100.0 * v / total for k, v in sorted(found.items(), key=lambda kv: -kv[1])}


def _report(data: Path) -> int:
    if not data.is_file():
        print(f"no perf data at {data} (record it with perf record, see --help)", file=sys.stderr)
        return 2
    if shutil.which("perf") is None:
        print("perf is not installed (linux-tools)", file=sys.stderr)
        return 2
    out = subprocess.run(
        ["perf", "report", "-i", str(data), "--no-children", "--sort", "dso,symbol", "--stdio"],
        capture_output=True, text=True, check=True,
    )  # fmt: skip
    found = shares(out.stdout)
    if not found:
        print("no samples in engine code or libm", file=sys.stderr)
        return 1
    for name, share in found.items():
        if share >= 0.2:
            print(f"{share:6.2f} %  {name}")
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog=__doc__.split("\n\n", 1)[1],
    )  # fmt: skip
    parser.add_argument("--face", choices=["X", "V", "S"], default="S")
    parser.add_argument("--h-over-d", type=float, default=0.5)
    parser.add_argument("--r-p", type=float, default=1.0)
    parser.add_argument("--seconds", type=float, default=30.0, help="time spent in maps")
    parser.add_argument(
        "--poses", type=Path,
        help="profile these poses instead of maps: an .npz with arrays x0 (D) and theta0 (rad)",
    )  # fmt: skip
    parser.add_argument(
        "--apart", action="store_true",
        help="keep every engine function apart (compiled with debug info, which numba marks "
        "noinline): each gets its own share, but calls cost more (maps about twice as slow), "
        "so small functions called often are over-counted",
    )  # fmt: skip
    parser.add_argument("--report", type=Path, help="print the shares of a recorded profile")
    argv = sys.argv[1:] if argv is None else argv
    args = parser.parse_args(argv)
    if args.report is not None:
        return _report(args.report)
    return _run(args, argv)


if __name__ == "__main__":
    sys.exit(main())
