"""The compiled engine that travels with the install, and how a run finds it.

Compiling the engine is what a fresh install's first simulation would pay: about 100 s of CPU
on these machines. So the build compiles it once (``python -m xface_core.precompile DIR``,
run by the wheel's build and by ``make setup``) for a generic CPU of the build machine's
architecture (``NUMBA_CPU_NAME=generic``: it runs at host speed, measured by
``scripts/bench/bench_generic_build.py``), in numba's own cache format, into
:data:`SHIPPED_DIR` with a :data:`MANIFEST_NAME` that says what it was built from.

At run time every cached engine kernel looks in two places (:class:`ShippedFunctionCache`):

1. numba's cache, as numba finds it (``__pycache__`` beside the source when writable, else the
   user's cache folder): what a compile on this machine wrote, keyed by this host's CPU;
2. the shipped build, keyed by the generic CPU it was built for, used only while its manifest
   matches this process: the same engine sources (:func:`._stale.source_digest`), the same
   numba (its index files also carry numba's version), the same Python (in the file names)
   and the same architecture (the LLVM triple).

A shipped build that does not match is never used: the engine compiles as it always did and
numba caches the result in place 1. The shipped folder is only read, so an install into a
site-packages the user cannot write still starts warm.
"""

from __future__ import annotations

import functools
import json
import os
import sys
from pathlib import Path
from typing import Any, NamedTuple

import numba
from numba.core.caching import FunctionCache, IndexDataCacheFile
from numba.core.runtime.nrt import rtsys

from ._stale import source_digest

__all__ = [
    "MANIFEST_NAME",
    "SHIPPED_DIR",
    "SHIPPED_DIR_ENV",
    "TYPICAL_COMPILE_CPU_S",
    "ShippedBuild",
    "ShippedFunctionCache",
    "compile_estimate_s",
    "has_compiled",
    "host_triple",
    "install",
    "manifest_problem",
    "read_manifest",
    "shipped_build",
    "write_manifest",
]

#: Names another folder to read the precompiled engine from (the build's own check, tests).
SHIPPED_DIR_ENV = "XFACE_PRECOMPILED_DIR"
#: Where the build puts the precompiled engine (package data of ``xface_core._engine``), or
#: the folder named by :data:`SHIPPED_DIR_ENV`.
SHIPPED_DIR = Path(os.environ.get(SHIPPED_DIR_ENV) or Path(__file__).resolve().parent / "_compiled")
#: The shipped build's description (JSON): see :func:`write_manifest`.
MANIFEST_NAME = "manifest.json"
#: The manifest layout this code reads.
MANIFEST_FORMAT = 1
#: CPU seconds a compile of the entry points took on these 2-core machines when no build
#: says otherwise (the build of the seven entry points: 77-84 s; a fresh install's first
#: ``xface predict`` compiled 84-112 s under load: docs/notes/2026-11-28-engine-compile-time.md).
TYPICAL_COMPILE_CPU_S = 90.0


def host_triple() -> str:
    """The LLVM target triple of this process (what a build must have been made for)."""
    import llvmlite.binding as llvm

    return str(llvm.get_process_triple())


def compile_estimate_s(manifest: dict[str, Any] | None) -> float:
    """CPU seconds a compile of the engine takes: the build's own measure when there is one
    (the same sources on a machine like this one), else :data:`TYPICAL_COMPILE_CPU_S`."""
    if manifest is not None:
        value = manifest.get("compile_cpu_s")
        if isinstance(value, int | float) and value > 0:
            return float(value)
    return TYPICAL_COMPILE_CPU_S


def _python_tag() -> str:
    return f"{sys.version_info[0]}.{sys.version_info[1]}"


def write_manifest(directory: Path, *, magic: tuple[Any, ...], compile_cpu_s: float) -> None:
    """Describe the build in ``directory``: the codegen's ``magic`` tuple (LLVM triple, CPU
    name, CPU features) the kernels were compiled for, and the CPU seconds the compile took
    (what a run that cannot use the build will spend compiling)."""
    manifest = {
        "format": MANIFEST_FORMAT,
        "numba": numba.__version__,
        "python": _python_tag(),
        "magic": list(magic),
        "sources": source_digest(),
        "compile_cpu_s": round(compile_cpu_s, 1),
    }
    (directory / MANIFEST_NAME).write_text(json.dumps(manifest, indent=1) + "\n")


def read_manifest(directory: Path = SHIPPED_DIR) -> dict[str, Any] | None:
    """The manifest of the build in ``directory``, or None (none there, or unreadable)."""
    try:
        data = json.loads((directory / MANIFEST_NAME).read_text())
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def manifest_problem(manifest: dict[str, Any] | None, triple: str) -> str | None:
    """Why a build with ``manifest`` cannot serve this process (LLVM ``triple``), or None."""
    if manifest is None:
        return "no precompiled engine in this install"
    checks = (
        ("format", MANIFEST_FORMAT, "a manifest of another layout"),
        ("numba", numba.__version__, "built with numba {got}, this is numba {want}"),
        ("python", _python_tag(), "built for Python {got}, this is Python {want}"),
        ("sources", source_digest(), "built from other engine sources"),
    )
    for key, want, why in checks:
        got = manifest.get(key)
        if got != want:
            return why.format(got=got, want=want)
    magic = manifest.get("magic")
    if not isinstance(magic, list) or len(magic) != 3 or magic[0] != triple:
        return f"built for another architecture ({magic[0] if magic else '?'}, this is {triple})"
    return None


class ShippedBuild(NamedTuple):
    """What the build in a folder is, and whether it can serve this process."""

    manifest: dict[str, Any] | None
    problem: str | None
    """Why it cannot serve (:func:`manifest_problem`), or None."""
    magic: tuple[Any, ...] | None
    """The codegen tuple its kernels are keyed by when it can serve, else None."""


@functools.cache
def shipped_build(directory: Path = SHIPPED_DIR) -> ShippedBuild:
    """The build in ``directory`` checked against this process, once per process (the files
    and the engine's sources do not change while it runs): every kernel's cache and
    ``runner.engine_state`` ask this one answer instead of each hashing the sources again."""
    manifest = read_manifest(directory)
    problem = manifest_problem(manifest, host_triple())
    magic = tuple(manifest["magic"]) if manifest is not None and problem is None else None
    return ShippedBuild(manifest, problem, magic)


class ShippedFunctionCache(FunctionCache):
    """numba's cache of one kernel, which on a miss loads the shipped build's copy.

    numba's own lookup comes first and is unchanged; the second one reads the index of the
    same name in :data:`SHIPPED_DIR` with the key the build wrote: the same signature and
    bytecode, the build's codegen (a generic CPU of this architecture) in place of this
    host's. Machine code for a generic CPU runs on every CPU of that architecture.
    """

    def __init__(self, py_func: Any, shipped_dir: Path = SHIPPED_DIR) -> None:
        super().__init__(py_func)  # type: ignore[no-untyped-call]
        self._shipped = IndexDataCacheFile(
            cache_path=str(shipped_dir),
            filename_base=self._impl.filename_base,
            source_stamp=self._impl.locator.get_source_stamp(),
        )
        self._shipped_dir = shipped_dir

    @property
    def shipped_magic(self) -> tuple[Any, ...] | None:
        """The shipped build's codegen tuple when it can serve this process, else None."""
        return shipped_build(self._shipped_dir).magic

    def shipped_key(self, sig: Any, codegen: Any) -> tuple[Any, ...] | None:
        """The key of ``sig`` in the shipped index, or None when the build cannot serve."""
        magic = self.shipped_magic
        if magic is None:
            return None
        sig_, _, code_hashes = self._index_key(sig, codegen)
        return (sig_, magic, code_hashes)

    def load_overload(self, sig: Any, target_context: Any) -> Any:
        """numba's ``load_overload`` without its ``target_context.refresh()``: only the
        runtime that the loaded machine code calls into is brought up first.

        The refresh imports and installs every lowering and typing registry numba has (its
        array, linalg, random, unicode, typed-container implementations): what a *compile*
        needs, 0.2-0.3 s of a process's first answer (0.29 of the first prediction's 0.39 s,
        cProfile). A compiled kernel loaded from a cache needs only what its code links
        against: numba's C helpers and Python's exception objects (added to LLVM's symbol
        table when the target context is made), libm (added when it is initialised) and the
        NRT (``rtsys.initialize``, here). A missing symbol would stop the load of the whole
        library, not one call, so loading every entry point (tests/core/engine/
        test_precompiled.py) shows none is missing. A cache miss compiles, and numba's
        compiler refreshes the contexts itself."""
        rtsys.initialize(target_context)
        with self._guard_against_spurious_io_errors():
            return self._load_overload(sig, target_context)

    def _load_overload(self, sig: Any, target_context: Any) -> Any:
        data = super()._load_overload(sig, target_context)  # type: ignore[no-untyped-call]
        if data is not None or not self._enabled:
            return data
        key = self.shipped_key(sig, target_context.codegen())
        if key is None:
            return None
        try:
            data = self._shipped.load(key)
        except Exception:  # a damaged shipped file: compile instead, as without one
            return None
        return None if data is None else self._impl.rebuild(target_context, data)


def install(dispatchers: list[Any], shipped_dir: Path = SHIPPED_DIR) -> None:
    """Give every cached kernel of ``dispatchers`` a :class:`ShippedFunctionCache` (before
    anything is compiled or loaded: the engine's ``__init__`` does it at import)."""
    for dispatcher in dispatchers:
        if isinstance(getattr(dispatcher, "_cache", None), FunctionCache):
            dispatcher._cache = ShippedFunctionCache(dispatcher.py_func, shipped_dir)


def has_compiled(dispatcher: Any, *, shipped: bool) -> bool:
    """True when ``dispatcher`` has compiled code for this process in numba's cache
    (``shipped=False``: keyed by this host's CPU) or in the shipped build (``shipped=True``),
    for any signature: what decides whether its first call compiles."""
    cache = getattr(dispatcher, "_cache", None)
    if not isinstance(cache, ShippedFunctionCache):
        return False
    if shipped:
        magic = cache.shipped_magic
        index = cache._shipped._load_index() if magic is not None else {}
    else:
        magic = dispatcher.targetctx.codegen().magic_tuple()
        index = cache._cache_file._load_index()
    return any(key[1] == magic for key in index)
