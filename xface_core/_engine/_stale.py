"""Drop the engine's numba cache when any of its sources changed.

numba's on-disk cache (``cache=True``) checks only the source file of the function it caches,
not the files of the functions it calls: after an edit of ``motion.py`` the cached
``simulate`` of ``simulate.py`` would still run the old motion code. The engine is cut into
many modules, so every import compares one digest of all of them (and of the codes they fold
in as constants) with the digest stored beside the cache, and empties the cache on a change.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

#: The file beside the cache that holds the digest of the sources it was compiled from.
STAMP_NAME = "xface-engine-sources.sha256"


def engine_sources() -> list[Path]:
    """The engine's modules and the code definitions they compile against."""
    here = Path(__file__).resolve().parent
    return [*sorted(here.glob("*.py")), here.parent / "codes.py", here.parent / "physics.py"]


def source_digest(files: list[Path] | None = None) -> str:
    """SHA-256 over the names and contents of ``files`` (default: :func:`engine_sources`)."""
    h = hashlib.sha256()
    for path in engine_sources() if files is None else files:
        h.update(path.name.encode())
        h.update(path.read_bytes())
    return h.hexdigest()


def drop_stale_cache(cache_dir: str | Path | None) -> bool:
    """Empty ``cache_dir`` of numba cache files unless its stamp matches the sources;
    returns True when it dropped them. Unwritable locations are left alone (numba then
    does not cache there either)."""
    if cache_dir is None:
        return False
    directory = Path(cache_dir)
    stamp = directory / STAMP_NAME
    digest = source_digest()
    try:
        if stamp.read_text() == digest:
            return False
    except OSError:
        pass
    try:
        directory.mkdir(parents=True, exist_ok=True)
        for pattern in ("*.nbi", "*.nbc"):
            for path in directory.glob(pattern):
                path.unlink(missing_ok=True)
        stamp.write_text(digest)
    except OSError:
        return False
    return True
