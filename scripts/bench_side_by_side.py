"""Time two versions of xface_core side by side in one process: the ratio after/before.

    python scripts/bench_side_by_side.py --before <git-rev> [--after <git-rev>|WORKTREE]
        [--repeats N] [--quick] [--out docs/bench/side_by_side.md] [--note TEXT]

A git revision's ``xface_core/`` is extracted (``git archive``) into a temporary directory as
a package of its own name (``xface_core_before``/``_after``), its absolute ``xface_core``
references (``resources.files("xface_core.data")``, doctests) rewritten; ``WORKTREE`` (the
default ``--after``) is the working tree's package. Numba caches by file path, so each copy
compiles its own kernels; both are warmed up first. Each repeat runs every workload before,
then after, so drift on a shared machine hits both alike; the table has per-call medians over
the repeats, their ratio, the range of the per-repeat ratios and of the repeats. Exit 1 if
the versions' outcomes differ on any workload, 2 if one cannot be loaded.
"""

from __future__ import annotations

import argparse
import gc
import importlib
import importlib.util
import inspect
import math
import os
import platform
import re
import shlex
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = "xface_core"
WORKTREE = "WORKTREE"
Design = tuple[str, float, float]  # kind, H/D, r_p
Pose = tuple[Design, float, float]  # design, x0 (D), theta0 (rad)
Pair = tuple[Callable[[], Any], Callable[[], Any]]  # the same call on before, after
MAPS: tuple[Design, ...] = (("X", 0.25, 2.0), ("X", 1.0, 1.0), ("V", 0.5, 1.0), ("S", 0.5, 1.0))
POSES: tuple[Pose, ...] = ((MAPS[0], 0.3, 0.2), (MAPS[2], 0.2, 0.3), (MAPS[3], 0.1, -0.2))
HEADER = (
    "| workload | calls/repeat | before (median) | after (median) | ratio after/before "
    "| per-repeat ratios min-max | before min-max | after min-max |"
)
_ABSOLUTE = re.compile(r"(\bfrom\s+|\bimport\s+|[\"'])xface_core\b")


@dataclass(frozen=True)
class Sizes:
    grid: int
    predict_calls: int
    map_calls: int
    maps: tuple[Design, ...]
    poses: tuple[Pose, ...]


FULL = Sizes(41, 300, 5, MAPS, POSES)
QUICK = Sizes(11, 5, 1, MAPS[:1], POSES[:1])


@dataclass
class Workload:
    kind: str  # "predict", "map" or "batch"
    name: str
    unit: str  # "us" or "ms"
    calls: int
    run: Pair
    times: tuple[list[float], list[float]] = field(default_factory=lambda: ([], []))


def git(*args: str) -> str:
    done = subprocess.run(["git", *args], cwd=ROOT, check=True, capture_output=True, text=True)
    return done.stdout.strip()


def resolve(rev: str) -> str:
    """The commit's full hash (HEAD may move while the benchmark runs), or WORKTREE."""
    return rev if rev == WORKTREE else git("rev-parse", "--verify", f"{rev}^{{commit}}")


def describe(rev: str) -> str:
    if rev != WORKTREE:
        return git("log", "-1", "--format=%h %s", rev)
    dirty = git("status", "--porcelain", "--", PACKAGE)
    state = "with uncommitted changes in xface_core" if dirty else "clean xface_core"
    return f"working tree (HEAD {git('rev-parse', '--short', 'HEAD')}, {state})"


def rewrite_absolute(package_dir: Path, name: str) -> int:
    """Point absolute ``xface_core`` imports and module-name strings at ``name``."""
    count = 0
    for path in sorted(package_dir.rglob("*.py")):
        text, n = _ABSOLUTE.subn(rf"\g<1>{name}", path.read_text("utf-8"))
        if n:
            path.write_text(text, "utf-8")
            count += n
    return count


def load_revision(sha: str, tmp: Path, name: str) -> tuple[ModuleType, int]:
    """Extract commit ``sha``'s xface_core into ``tmp/name``; import it as package ``name``."""
    archive = subprocess.run(["git", "archive", sha, PACKAGE], cwd=ROOT, check=True,
                             capture_output=True).stdout  # fmt: skip
    subprocess.run(["tar", "-x", "-C", str(tmp)], input=archive, check=True)
    package_dir = tmp / name
    (tmp / PACKAGE).rename(package_dir)
    rewrites = rewrite_absolute(package_dir, name)
    init, search = package_dir / "__init__.py", [str(package_dir)]
    spec = importlib.util.spec_from_file_location(name, init, submodule_search_locations=search)
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except Exception as exc:
        raise ImportError(f"{sha[:12]}'s {PACKAGE} does not import as {name}: {exc!r}") from exc
    return module, rewrites


def load_worktree() -> ModuleType:
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))
    try:
        module = importlib.import_module(PACKAGE)
    except Exception as exc:  # a tree caught mid-change
        raise ImportError(f"the working tree's {PACKAGE} does not import: {exc!r}") from exc
    where = Path(module.__file__ or "").resolve().parent
    if where != ROOT / PACKAGE:
        raise ImportError(f"{PACKAGE} was imported from {where}, not from {ROOT / PACKAGE}")
    return module


def load_sides(args: argparse.Namespace, tmp: Path) -> tuple[list[ModuleType], list[str]]:
    modules, notes = [], []
    for role, rev in (("before", args.before), ("after", args.after)):
        if rev == WORKTREE:
            modules.append(load_worktree())
            continue
        name = f"{PACKAGE}_{role}"
        while name in sys.modules:
            name += "_"
        module, rewrites = load_revision(rev, tmp, name)
        modules.append(module)
        if rewrites:
            notes.append(f"{role}: rewrote {rewrites} absolute `{PACKAGE}` references to {name}")
    return modules, notes


def warm_up(xf: ModuleType) -> float:
    """Compile (or load from numba's cache) what the workloads call; the seconds it took."""
    start = time.perf_counter()
    xf.predict(xf.make_face(*MAPS[0]), 0.3, 0.2)
    xf.acceptance_map(xf.make_face(*MAPS[0]), grid=11)
    return time.perf_counter() - start


def threads_kw(modules: Sequence[ModuleType], function: str) -> dict[str, int]:
    """``threads=1`` if every version's ``function`` takes that keyword, else nothing."""
    has = [("threads" in inspect.signature(getattr(m, function)).parameters) for m in modules]
    return {"threads": 1} if all(has) else {}


def bind(modules: Sequence[ModuleType], design: Design, call: Callable[..., Any]) -> Pair:
    """``call(xf, face)`` for each version, with its own module and its own face object."""

    def one(xf: ModuleType) -> Callable[[], Any]:
        face = xf.make_face(*design)
        return lambda: call(xf, face)

    return one(modules[0]), one(modules[1])


def build_workloads(modules: Sequence[ModuleType], sizes: Sizes) -> list[Workload]:
    map_kw, batch_kw = threads_kw(modules, "acceptance_map"), threads_kw(modules, "predict_batch")
    g, xf0 = sizes.grid, modules[0]
    x0, th = np.meshgrid(xf0.x0_grid(g), xf0.theta_grid(g), indexing="ij")
    out = []
    for d, x, t in sizes.poses:
        run = bind(modules, d, lambda xf, f, x=x, t=t: xf.predict(f, x, t))
        out.append(Workload("predict", f"predict {label(d)} at ({x}, {t})", "us",
                            sizes.predict_calls, run))  # fmt: skip
    for d in sizes.maps:
        run = bind(modules, d, lambda xf, f: xf.acceptance_map(f, grid=g, **map_kw))
        out.append(Workload("map", f"map {label(d)} {g}x{g}", "ms", sizes.map_calls, run))
        run = bind(modules, d, lambda xf, f: xf.predict_batch(f, x0 * f.width, th, **batch_kw))
        out.append(Workload("batch", f"batch {label(d)} {g}x{g}", "ms", sizes.map_calls, run))
    return out


def label(design: Design) -> str:
    kind, h, rp = design
    return f"{kind} {h:g}/{rp:g}"


def outcomes(result: Any) -> np.ndarray:
    """AcceptanceMap.outcomes, BatchResult.outcome or Prediction.outcome as int codes."""
    codes = result.outcomes if hasattr(result, "outcomes") else result.outcome
    return np.asarray(codes, dtype=np.int64)


def compare(workloads: Sequence[Workload], seated_code: int) -> tuple[list[str], bool]:
    """One line per workload: do both versions give the same outcomes?"""
    lines, same = [], True
    for w in workloads:
        a, b = (outcomes(run()) for run in w.run)
        if a.shape == b.shape and np.array_equal(a, b):
            seated = int(np.count_nonzero(a == seated_code))
            lines.append(f"identical outcomes: {w.name} (poses {a.size}, seated {seated})")
        else:
            same = False
            n = int(np.count_nonzero(a != b)) if a.shape == b.shape else a.size
            lines.append(f"OUTCOMES DIFFER: {w.name} (in {n} of {a.size} poses)")
    return lines, same


def measure(workloads: Sequence[Workload], repeats: int) -> None:
    """Per-call seconds of every workload, ``repeats`` times, sides interleaved."""
    for _ in range(repeats):
        for w in workloads:
            for side in (0, 1):
                run = w.run[side]
                gc.collect()  # both sides start from the same heap state
                start = time.perf_counter()
                for _ in range(w.calls):
                    run()
                w.times[side].append((time.perf_counter() - start) / w.calls)


def table(workloads: Sequence[Workload]) -> list[str]:
    rows = [HEADER, "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    ratios: dict[str, list[float]] = {}
    for w in workloads:
        b, a = (np.asarray(t) * {"us": 1e6, "ms": 1e3}[w.unit] for t in w.times)
        mb, ma, paired = statistics.median(b), statistics.median(a), a / b
        ratios.setdefault(w.kind, []).append(ma / mb)
        rows.append(
            f"| {w.name} | {w.calls} | {mb:.4g} {w.unit} | {ma:.4g} {w.unit} | {ma / mb:.3f} "
            f"| {paired.min():.3f}-{paired.max():.3f} "
            f"| {b.min():.4g}-{b.max():.4g} | {a.min():.4g}-{a.max():.4g} |"
        )
    for kind, rs in ratios.items():
        geo = math.exp(statistics.fmean(math.log(r) for r in rs))
        rows.append(f"| every {kind} (geometric mean) | | | | {geo:.3f} | | | |")
    return rows


def machine_note() -> str:
    import numba

    usable = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else "?"
    load = ", ".join(f"{x:.2f}" for x in os.getloadavg())
    return (
        f"{os.cpu_count()} CPUs ({usable} usable), {platform.machine()}, Python "
        f"{platform.python_version()}, numba {numba.__version__}, numpy {np.__version__}; "
        f"load average {load} (1, 5, 15 min) at the end"
    )


def report(args: argparse.Namespace, argv: Sequence[str], info: dict[str, Any]) -> str:
    modules, warm = info["modules"], info["warmup_s"]
    head = [
        "# Side-by-side timing: before vs after",
        "",
        *([f"> {args.note}", ""] if args.note else []),
        f"- before: `{info['described'][0]}` (imported as `{modules[0].__name__}`)",
        f"- after: `{info['described'][1]}` (imported as `{modules[1].__name__}`)",
        (
            f"- {args.repeats} repeats per side, interleaved; per-call medians; "
            f"{'quick' if args.quick else 'full'} workloads; threads: {info['threads']}; "
            f"warm-up (compile or cache load) {warm[0]:.1f} s before, {warm[1]:.1f} s after"
        ),
        f"- machine: {machine_note()}; {datetime.now(UTC):%Y-%m-%d %H:%M} UTC",
        f"- command: `python scripts/bench_side_by_side.py {shlex.join(argv)}`",
        "",
    ]
    return "\n".join([*head, *info["body"]]) + "\n"


def parse(argv: Sequence[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    parser.add_argument("--before", required=True, help="git revision of the old version")
    parser.add_argument("--after", default=WORKTREE, help="git revision or WORKTREE (default)")
    parser.add_argument("--repeats", type=int, default=11, help="repeats per side (default 11)")
    parser.add_argument("--quick", action="store_true", help="tiny workloads (for the tests)")
    parser.add_argument("--out", type=Path, help="also write the Markdown report here")
    parser.add_argument("--note", default="", help="a line to put at the top of the report")
    args = parser.parse_args(argv)
    if args.repeats < 1:
        parser.error("--repeats must be >= 1")
    return args


def run_both(args: argparse.Namespace, tmp: Path) -> tuple[dict[str, Any], bool]:
    """Load, warm up, check outcomes and time both versions; the report's parts."""
    args.before, args.after = resolve(args.before), resolve(args.after)
    described = [describe(args.before), describe(args.after)]
    modules, notes = load_sides(args, tmp)
    warmup_s = [warm_up(xf) for xf in modules]
    workloads = build_workloads(modules, QUICK if args.quick else FULL)
    checks, same = compare(workloads, int(modules[0].Outcome.SEATED))
    print("\n".join(checks), file=sys.stderr, flush=True)
    measure(workloads, args.repeats)
    threads = ", ".join(
        f"{f} {'threads=1' if threads_kw(modules, f) else 'default'}"
        for f in ("acceptance_map", "predict_batch")
    )
    body = [*table(workloads), "", *(f"- {line}" for line in [*checks, *notes])]
    info = {"modules": modules, "warmup_s": warmup_s, "threads": threads, "body": body}
    return {**info, "described": described}, same


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    args = parse(argv)
    names_before = set(sys.modules)
    with tempfile.TemporaryDirectory(prefix="xface_side_by_side_") as tmp:
        try:
            info, same = run_both(args, Path(tmp))
        except (subprocess.CalledProcessError, ImportError) as exc:
            detail = getattr(exc, "stderr", None) or exc
            print(f"error: {detail}".strip(), file=sys.stderr)
            return 2
        finally:
            for name in set(sys.modules) - names_before:  # the extracted copies go with tmp
                if name.startswith(f"{PACKAGE}_"):
                    del sys.modules[name]
    text = report(args, argv, info)
    print(text, end="")
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(text, "utf-8")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
