"""Time two versions of xface_core side by side: the ratio after/before.

    python scripts/bench/bench_side_by_side.py --before <git-rev> [--after <git-rev>|WORKTREE]
        [--repeats N] [--quick] [--only predict,map,batch,table] [--cpu host|generic]
        [--out docs/notes/DATE-side-by-side-SUBJECT.md] [--note TEXT]

A git revision's ``xface_core/`` is extracted (``git archive``) into a temporary directory as
a package of its own name (``xface_core_before``/``_after``), its absolute ``xface_core``
references (``resources.files("xface_core.data")``, doctests) rewritten; ``WORKTREE`` (the
default ``--after``) is the working tree's package, copied the same way without its numba
caches. So both versions are compiled here for this machine: the working tree's own package
would run the shipped build compiled for a generic CPU (and whatever its ``__pycache__``
holds), which made the working tree's predictions about 1.04 times slower than the same code
extracted from a commit. ``--cpu generic`` compiles both copies for a generic CPU of this
architecture instead, the shipped build's codegen: the same change to the scan has moved the
two builds by different amounts, by up to 15 %
(docs/notes/2026-11-30-where-a-cell-spends-its-cycles.md). Each version runs in a process of its own
(this script with ``--serve``), driven over a pipe: in one process the version imported
second paid about 150 us per kernel call in numba's dispatch (both versions' records are
tuples of the same element types, so they share one type fingerprint and the second version's
calls miss numba's fast path), which made a version look slower than itself. Numba caches by
file path, so each copy compiles its own kernels; both are warmed up first. Each repeat starts
a fresh process per side (loading from numba's cache) and runs every workload before, then
after, so drift on a shared machine hits both alike, and where a process's code and stack
happen to land (worth 0.8-1.0 of a map's time between processes) is sampled, not fixed for the
whole run; the table has per-call medians over the repeats, their ratio, the range of the
per-repeat ratios and of the repeats. Exit 1 if the versions' outcomes differ on any workload,
2 if one cannot be loaded.
"""

from __future__ import annotations

import argparse
import contextlib
import gc
import importlib
import importlib.util
import inspect
import json
import math
import os
import platform
import re
import shlex
import shutil
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

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = "xface_core"
WORKTREE = "WORKTREE"
Design = tuple[str, float, float]  # kind, H/D, r_p
Pose = tuple[Design, float, float]  # design, x0 (D), theta0 (rad)
MAPS: tuple[Design, ...] = (("X", 0.25, 2.0), ("X", 1.0, 1.0), ("V", 0.5, 1.0), ("S", 0.5, 1.0))
POSES: tuple[Pose, ...] = ((MAPS[0], 0.3, 0.2), (MAPS[2], 0.2, 0.3), (MAPS[3], 0.1, -0.2))
HEADER = (
    "| workload | calls/repeat | before (median) | after (median) | ratio after/before "
    "| per-repeat ratios min-max | before min-max | after min-max |"
)
_ABSOLUTE = re.compile(r"(\bfrom\s+|\bimport\s+|[\"'])xface_core\b")


#: What ``xface table --face all`` computes: the paper's table of every face (its designs,
#: 41 x 41 maps), one worker process so that the code is timed, not the pool.
TABLES = ("X", "V", "S")


@dataclass(frozen=True)
class Sizes:
    grid: int
    predict_calls: int
    map_calls: int
    maps: tuple[Design, ...]
    poses: tuple[Pose, ...]
    tables: tuple[str, ...]
    table_designs: dict[str, tuple[float, ...]] = field(default_factory=dict)
    """``m_table``'s ``h_over_d`` and ``r_p`` (empty: the paper's)."""


FULL = Sizes(41, 300, 5, MAPS, POSES, TABLES)
QUICK = Sizes(11, 5, 1, MAPS[:1], POSES[:1], TABLES[:1], {"h_over_d": (0.25,), "r_p": (2.0,)})


#: The kinds of workload, as ``--only`` names them.
KINDS = ("predict", "map", "batch", "table")


@dataclass
class Workload:
    kind: str  # one of KINDS
    name: str
    unit: str  # "us", "ms" or "s"
    calls: int
    index: int = -1
    """Its call's place in :func:`workload_calls` (the served process builds them all)."""
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


def extract_revision(sha: str, tmp: Path, name: str) -> int:
    """Extract commit ``sha``'s xface_core into ``tmp/name``, importable as package ``name``
    from ``tmp``; returns how many absolute references were rewritten."""
    archive = subprocess.run(["git", "archive", sha, PACKAGE], cwd=ROOT, check=True,
                             capture_output=True).stdout  # fmt: skip
    subprocess.run(["tar", "-x", "-C", str(tmp)], input=archive, check=True)
    package_dir = tmp / name
    (tmp / PACKAGE).rename(package_dir)
    return rewrite_absolute(package_dir, name)


def copy_worktree(tmp: Path, name: str) -> int:
    """Copy the working tree's xface_core into ``tmp/name`` as :func:`extract_revision`
    extracts a commit's (without ``__pycache__`` and the shipped ``_compiled`` build, which
    git does not hold either); returns how many absolute references were rewritten."""
    ignore = shutil.ignore_patterns("__pycache__", "_compiled")
    shutil.copytree(ROOT / PACKAGE, tmp / name, ignore=ignore)
    return rewrite_absolute(tmp / name, name)


def load_served(name: str, where: str) -> ModuleType:
    """The version a ``--serve`` process times: the copy ``name`` in directory ``where``."""
    sys.path.insert(0, where)
    try:
        return importlib.import_module(name)
    except Exception as exc:
        raise ImportError(f"{name} does not import: {exc!r}") from exc


def warm_up(xf: ModuleType) -> float:
    """Compile (or load from numba's cache) what the workloads call; the seconds it took."""
    start = time.perf_counter()
    xf.predict(xf.make_face(*MAPS[0]), 0.3, 0.2)
    xf.acceptance_map(xf.make_face(*MAPS[0]), grid=11)
    return time.perf_counter() - start


def takes_threads(xf: ModuleType) -> dict[str, bool]:
    """Which of the timed functions take ``threads=``."""
    return {
        f: "threads" in inspect.signature(getattr(xf, f)).parameters
        for f in ("acceptance_map", "predict_batch")
    }


def workloads(sizes: Sizes) -> list[Workload]:
    """The workloads, in the order :func:`workload_calls` builds their calls."""
    g, out = sizes.grid, []
    for d, x, t in sizes.poses:
        out.append(Workload("predict", f"predict {label(d)} at ({x}, {t})", "us",
                            sizes.predict_calls))  # fmt: skip
    for d in sizes.maps:
        out.append(Workload("map", f"map {label(d)} {g}x{g}", "ms", sizes.map_calls))
        out.append(Workload("batch", f"batch {label(d)} {g}x{g}", "ms", sizes.map_calls))
    for face in sizes.tables:
        designs = "the paper's designs" if not sizes.table_designs else "one design"
        out.append(Workload("table", f"table {face}, {designs}, {g}x{g}, 1 worker", "s", 1))
    for k, w in enumerate(out):
        w.index = k
    return out


def workload_calls(
    xf: ModuleType, sizes: Sizes, map_kw: dict[str, int], batch_kw: dict[str, int]
) -> list[Callable[[], Any]]:
    """One call per workload of :func:`workloads`, on version ``xf``."""
    g = sizes.grid
    x0, th = np.meshgrid(xf.x0_grid(g), xf.theta_grid(g), indexing="ij")
    out: list[Callable[[], Any]] = []
    for d, x, t in sizes.poses:
        face = xf.make_face(*d)
        out.append(lambda f=face, x=x, t=t: xf.predict(f, x, t))
    for d in sizes.maps:
        face = xf.make_face(*d)
        out.append(lambda f=face: xf.acceptance_map(f, grid=g, **map_kw))
        out.append(lambda f=face: xf.predict_batch(f, x0 * f.width, th, **batch_kw))
    for kind in sizes.tables:
        out.append(lambda k=kind: xf.m_table(k, grid=g, workers=1, **sizes.table_designs))
    return out


def serve(name: str, where: str) -> int:
    """``--serve NAME DIR``: time one version in this process, driven by the parent over
    stdin/stdout (one JSON object a line each way)."""
    channel, sys.stdout = sys.stdout, sys.stderr  # only replies go to the parent

    def reply(**fields: Any) -> None:
        channel.write(json.dumps(fields) + "\n")
        channel.flush()

    try:
        xf = load_served(name, where)
    except ImportError as exc:
        reply(error=str(exc))
        return 2
    calls: list[Callable[[], Any]] = []
    for line in sys.stdin:
        cmd = json.loads(line)
        op = cmd["op"]
        if op == "hello":
            from numba.core import config

            cpu = "generic" if config.CPU_NAME == "generic" else "host"
            reply(threads=takes_threads(xf), seated=int(xf.Outcome.SEATED), cpu=cpu)
        elif op == "setup":
            sizes = QUICK if cmd["quick"] else FULL
            warm = warm_up(xf)
            calls = workload_calls(xf, sizes, cmd["map_kw"], cmd["batch_kw"])
            reply(warmup=warm)
        elif op == "outcomes":
            reply(codes=outcomes(calls[cmd["index"]]()).tolist())
        elif op == "time":
            run, n = calls[cmd["index"]], cmd["calls"]
            gc.collect()  # both sides start from a collected heap
            start = time.perf_counter()
            for _ in range(n):
                run()
            reply(seconds=(time.perf_counter() - start) / n)
        else:
            reply(done=True)
            break
    return 0


class Side:
    """One version in its own ``--serve`` process."""

    def __init__(self, name: str, where: Path, env: dict[str, str] | None = None) -> None:
        self.name = name
        cmd = [sys.executable, str(Path(__file__).resolve()), "--serve", name, str(where)]
        self.proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     text=True, cwd=ROOT, env=env)  # fmt: skip

    def ask(self, op: str, **fields: Any) -> dict[str, Any]:
        assert self.proc.stdin is not None
        assert self.proc.stdout is not None
        if self.proc.poll() is None:
            self.proc.stdin.write(json.dumps({"op": op, **fields}) + "\n")
            self.proc.stdin.flush()
        line = self.proc.stdout.readline()
        if not line:
            raise ImportError(f"{self.name}'s process ended (exit {self.proc.wait()})")
        answer: dict[str, Any] = json.loads(line)
        if "error" in answer:
            raise ImportError(answer["error"])
        return answer

    def close(self) -> None:
        if self.proc.poll() is None:
            with contextlib.suppress(ImportError, OSError):
                self.ask("quit")
        self.proc.wait()


def start_sides(
    args: argparse.Namespace, tmp: Path, *, extract: bool = True
) -> tuple[list[Side], list[str]]:
    """A serving process per side; ``extract``: extract the revisions first (else they are
    in ``tmp`` already)."""
    sides, notes = [], []
    # The shipped build's codegen (xface_core.precompile), or this machine's whatever the
    # caller's environment says: numba keys its cache by the CPU, so each copy compiles for
    # the one asked into its own cache.
    from xface_core.precompile import GENERIC_CPU

    env = {key: value for key, value in os.environ.items() if key not in GENERIC_CPU}
    if args.cpu == "generic":
        env.update(GENERIC_CPU)
    for role, rev in (("before", args.before), ("after", args.after)):
        name = f"{PACKAGE}_{role}"
        rewrites = 0
        if extract:
            rewrites = (
                copy_worktree(tmp, name) if rev == WORKTREE else extract_revision(rev, tmp, name)
            )
        sides.append(Side(name, tmp, env))
        if rewrites:
            notes.append(f"{role}: rewrote {rewrites} absolute `{PACKAGE}` references to {name}")
    return sides, notes


def label(design: Design) -> str:
    kind, h, rp = design
    return f"{kind} {h:g}/{rp:g}"


def outcomes(result: Any) -> np.ndarray:
    """AcceptanceMap.outcomes, BatchResult.outcome or Prediction.outcome as int codes, or
    an MTable's seated counts M."""
    if hasattr(result, "outcomes"):  # a map (its M is a count; its outcomes are compared)
        return np.asarray(result.outcomes, dtype=np.int64)
    codes = result.M if hasattr(result, "M") else result.outcome
    return np.asarray(codes, dtype=np.int64)


def compare(sides: Sequence[Side], loads: Sequence[Workload], seated_code: int
            ) -> tuple[list[str], bool]:  # fmt: skip
    """One line per workload: do both versions give the same outcomes?"""
    lines, same = [], True
    for w in loads:
        a, b = (np.asarray(side.ask("outcomes", index=w.index)["codes"]) for side in sides)
        table = w.kind == "table"  # a table's codes are its M per design
        if a.shape == b.shape and np.array_equal(a, b):
            seated = int(np.count_nonzero(a == seated_code))
            detail = f"{a.size} designs" if table else f"poses {a.size}, seated {seated}"
            lines.append(f"identical {'M' if table else 'outcomes'}: {w.name} ({detail})")
        else:
            same = False
            n = int(np.count_nonzero(a != b)) if a.shape == b.shape else a.size
            what = ("M DIFFERS", "designs") if table else ("OUTCOMES DIFFER", "poses")
            lines.append(f"{what[0]}: {w.name} (in {n} of {a.size} {what[1]})")
    return lines, same


def measure(
    args: argparse.Namespace, tmp: Path, setup: dict[str, Any], loads: Sequence[Workload]
) -> None:
    """Per-call seconds of every workload, ``args.repeats`` times, sides interleaved, each
    repeat in a fresh pair of processes (numba's cache makes their start a second or two).

    One process per side for the whole run measured where that process's code and stack
    happened to land as much as the code: the same kernel timed 55.8-71.2 ms a map in four
    processes, and two versions that differ by 0.82 gave 0.70 in one pair of processes
    (docs/notes/2026-11-29-side-by-side-memo-look-ups-inlined.md)."""
    for _ in range(args.repeats):
        sides, _ = start_sides(args, tmp, extract=False)
        try:
            for side in sides:
                side.ask("setup", **setup)
            for w in loads:
                for side in (0, 1):
                    seconds = sides[side].ask("time", index=w.index, calls=w.calls)["seconds"]
                    w.times[side].append(seconds)
        finally:
            for side in sides:
                side.close()


def table(workloads: Sequence[Workload]) -> list[str]:
    rows = [HEADER, "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    ratios: dict[str, list[float]] = {}
    for w in workloads:
        b, a = (np.asarray(t) * {"us": 1e6, "ms": 1e3, "s": 1.0}[w.unit] for t in w.times)
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
    names, warm = info["names"], info["warmup_s"]
    head = [
        "# Side-by-side timing: before vs after",
        "",
        *([f"> {args.note}", ""] if args.note else []),
        f"- before: `{info['described'][0]}` (imported as `{names[0]}`, own processes)",
        f"- after: `{info['described'][1]}` (imported as `{names[1]}`, own processes)",
        (
            f"- {args.repeats} repeats per side, interleaved, each in a fresh process; "
            f"per-call medians; "
            f"{'quick' if args.quick else 'full'} workloads ({', '.join(args.only)}); "
            f"threads: {info['threads']}; compiled for the {args.cpu} CPU; "
            f"warm-up (compile or cache load) {warm[0]:.1f} s before, {warm[1]:.1f} s after"
        ),
        f"- machine: {machine_note()}; {datetime.now(UTC):%Y-%m-%d %H:%M} UTC",
        f"- command: `python scripts/bench/bench_side_by_side.py {shlex.join(argv)}`",
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
    parser.add_argument(
        "--cpu",
        choices=("host", "generic"),
        default="host",
        help="compile both copies for this machine's CPU (default) or for a generic CPU of its "
        "architecture, as the shipped build is",
    )
    parser.add_argument(
        "--only",
        default=",".join(KINDS),
        help=f"comma-separated kinds of workload (default: all: {','.join(KINDS)})",
    )
    args = parser.parse_args(argv)
    if args.repeats < 1:
        parser.error("--repeats must be >= 1")
    args.only = [kind.strip() for kind in args.only.split(",") if kind.strip()]
    unknown = sorted(set(args.only) - set(KINDS))
    if unknown or not args.only:
        parser.error(f"--only takes kinds among {', '.join(KINDS)}, got {args.only}")
    return args


def run_both(args: argparse.Namespace, tmp: Path) -> tuple[dict[str, Any], bool]:
    """Start, warm up, check outcomes and time both versions; the report's parts."""
    args.before, args.after = resolve(args.before), resolve(args.after)
    described = [describe(args.before), describe(args.after)]
    sides, notes = start_sides(args, tmp)
    try:
        hellos = [side.ask("hello") for side in sides]
        kws = {
            f: ({"threads": 1} if all(h["threads"][f] for h in hellos) else {})
            for f in ("acceptance_map", "predict_batch")
        }
        setup = {"quick": args.quick, "map_kw": kws["acceptance_map"],
                 "batch_kw": kws["predict_batch"]}  # fmt: skip
        cpus = {h["cpu"] for h in hellos}
        if cpus != {args.cpu}:
            raise ImportError(f"the sides compile for {sorted(cpus)}, not for {args.cpu}")
        warmup_s = [side.ask("setup", **setup)["warmup"] for side in sides]
        loads = [w for w in workloads(QUICK if args.quick else FULL) if w.kind in args.only]
        checks, same = compare(sides, loads, int(hellos[0]["seated"]))
        print("\n".join(checks), file=sys.stderr, flush=True)
    finally:
        for side in sides:
            side.close()
    measure(args, tmp, setup, loads)
    threads = ", ".join(f"{f} {'threads=1' if kw else 'default'}" for f, kw in kws.items())
    body = [*table(loads), "", *(f"- {line}" for line in [*checks, *notes])]
    info = {"names": [side.name for side in sides], "warmup_s": warmup_s, "threads": threads,
            "body": body}  # fmt: skip
    return {**info, "described": described}, same


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:1] == ["--serve"] and len(argv) == 3:
        return serve(argv[1], argv[2])
    args = parse(argv)
    with tempfile.TemporaryDirectory(prefix="xface_side_by_side_") as tmp:
        try:
            info, same = run_both(args, Path(tmp))
        except (subprocess.CalledProcessError, ImportError) as exc:
            detail = getattr(exc, "stderr", None) or exc
            print(f"error: {detail}".strip(), file=sys.stderr)
            return 2
    text = report(args, argv, info)
    print(text, end="")
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(text, "utf-8")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
