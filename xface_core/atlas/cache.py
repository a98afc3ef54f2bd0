"""The acceptance atlas's file in a cache folder: written atomically, trusted only after checks.

A cache folder may be shared (two robots, two processes), left behind by a crash, or hold
files that someone or something altered. So:

- **Writing** goes to a temporary file of a unique name in the same folder, flushed to disk,
  then renamed over the target (``os.replace``, atomic): a reader sees the old file or the new
  one, never half of one, and two writers of the same atlas never trip over each other.
- **Reading** trusts nothing in the file: it must open as an ``.npz`` (never with pickle),
  hold exactly the atlas's arrays, each with the dtype and shape of the requested grid, the
  requested key, format and grid, valid :class:`~xface_core.codes.Outcome` codes, and a
  SHA-256 checksum of all of it that matches. Anything else raises
  :class:`UnusableAtlasFile` with the reason; :func:`~xface_core.atlas.build.build_atlas`
  then rebuilds the atlas, replaces the file and warns once (:class:`AtlasCacheWarning`).

The checksum finds damage (a torn write, a flipped bit, an edited array); it is not a
signature: whoever may write to the folder can write a valid file.
"""

from __future__ import annotations

import hashlib
import os
import uuid
import warnings
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from xface_core.codes import Outcome

__all__ = [
    "ATLAS_FORMAT",
    "AtlasCacheWarning",
    "UnusableAtlasFile",
    "cache_path",
    "is_directory",
    "read_atlas_file",
    "warn_cache",
    "write_atlas_file",
]

#: Bumped whenever the stored arrays or their meaning change (part of the cache key, and
#: stored in the file). 2: the file holds its format and a checksum.
ATLAS_FORMAT = 2

#: Slack per stored array for the ``.npy`` header (numpy refuses headers above 10,000 bytes).
_HEADER_BYTES = 16_384
_ZIP_MAGIC = b"PK\x03\x04"
_VALID_OUTCOMES = np.array([int(o) for o in Outcome], dtype=np.int8)


class AtlasCacheWarning(UserWarning):
    """A cached atlas file could not be used or written (the message names the file and the
    reason). Nothing is lost: :func:`~xface_core.atlas.build.build_atlas` builds the atlas and
    returns it, and replaces the file when it can."""


class UnusableAtlasFile(Exception):
    """A cache file that is not the requested atlas, intact (the message says why)."""


def cache_path(cache_dir: str | Path, key: str) -> Path:
    """The file of the atlas with ``key`` (:func:`~xface_core.atlas.build.atlas_key`) in
    ``cache_dir`` (``~`` expanded): where :func:`~xface_core.atlas.build.build_atlas` reads and
    writes it."""
    return Path(cache_dir).expanduser() / f"atlas-{key}.npz"


def is_directory(path: Path) -> bool:
    """True when ``path`` is a directory (False when it cannot be told: no permission)."""
    try:
        return path.is_dir()
    except OSError:
        return False


def warn_cache(message: str, report: Callable[[str], object] | None = None) -> None:
    """Report a cache problem to ``report``, else as one :class:`AtlasCacheWarning` pointing
    at the caller of ``build_atlas`` (which calls the helper that calls this)."""
    if report is not None:
        report(message)
    else:
        warnings.warn(message, AtlasCacheWarning, stacklevel=4)


def checksum(arrays: Mapping[str, npt.NDArray[np.generic]]) -> str:
    """SHA-256 (hex) of every array's name, dtype, shape and bytes, in name order."""
    digest = hashlib.sha256()
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        digest.update(f"{name}|{a.dtype.str}|{a.shape}|".encode())
        digest.update(a.tobytes())
    return digest.hexdigest()


def write_atlas_file(path: Path, arrays: Mapping[str, npt.NDArray[np.generic]]) -> Path:
    """Write ``arrays`` with their checksum to ``path`` (its folder created if absent):
    to a temporary file of a unique name in the same folder, synced, then renamed over
    ``path``. Raises ``OSError`` when the folder cannot be written (the temporary file is
    removed)."""
    stored: dict[str, Any] = {**arrays, "checksum": np.array(checksum(arrays))}
    path.parent.mkdir(parents=True, exist_ok=True)
    # Not tempfile.mkstemp: its files are private to their owner (0600), and a cache shared by
    # two robots' users needs the permissions of any other file the process makes (umask).
    tmp = path.with_name(f".{path.name}.{os.getpid()}.{uuid.uuid4().hex}.tmp")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    try:
        with os.fdopen(fd, "wb") as stream:
            np.savez_compressed(stream, **stored)
            stream.flush()
            os.fsync(stream.fileno())  # the data on disk before the name: a crash leaves either
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


def _expected_layout(
    n: int, m: int, flips: int, key_chars: int
) -> dict[str, tuple[np.dtype[np.generic], tuple[int, ...]]]:
    """The dtype and shape of every stored array on an ``n`` x ``m`` grid with ``flips``
    grid-line flips and a key of ``key_chars`` characters."""
    return {
        "key": (np.dtype(f"<U{key_chars}"), ()),
        "format": (np.dtype(np.int64), ()),
        "x0": (np.dtype(np.float64), (n,)),
        "theta0": (np.dtype(np.float64), (m,)),
        "outcomes": (np.dtype(np.int8), (n, m)),
        "simulated": (np.dtype(np.bool_), (n, m)),
        "start_clearance": (np.dtype(np.float64), ()),
        "flip_keys": (np.dtype(np.int64), (flips, 3)),
        "flip_brackets": (np.dtype(np.float64), (flips, 2)),
        "checksum": (np.dtype("<U64"), ()),
    }


def _read_arrays(path: Path, n: int, m: int) -> dict[str, npt.NDArray[np.generic]]:
    """Every array of the file on an ``n`` x ``m`` grid, after checking that it is an
    ``.npz`` with the atlas's members, none larger than such an atlas could need."""
    try:
        if is_directory(path):
            raise UnusableAtlasFile("it is a directory, not a file")
        # Opened here, not by np.load, which leaves its file open when the zip is bad.
        with path.open("rb") as stream:
            magic = stream.read(len(_ZIP_MAGIC))
            if magic != _ZIP_MAGIC:  # np.load would take it for a pickle or a lone .npy
                raise UnusableAtlasFile("it is empty" if not magic else "not an .npz archive")
            stream.seek(0)
            with np.load(stream, allow_pickle=False) as data:
                return _npz_arrays(data, n, m)
    except (UnusableAtlasFile, FileNotFoundError, NotADirectoryError):
        raise  # checked, or no file there (NotADirectoryError: the folder is a file)
    except Exception as exc:  # any failure of the parsers means: not usable
        # A damaged zip or .npy fails in more ways than zipfile and numpy document: BadZipFile,
        # zlib.error, EOFError, ValueError (bad header, too little data), NotImplementedError
        # (a compression method), RuntimeError (a set "encrypted" flag), MemoryError (a header
        # asking for an absurd array), OSError... This block only parses; the checks of what
        # was read run outside it, so their own errors are not hidden.
        raise UnusableAtlasFile(f"unreadable ({type(exc).__name__}: {exc})") from exc


def _npz_arrays(data: np.lib.npyio.NpzFile, n: int, m: int) -> dict[str, npt.NDArray[Any]]:
    """The arrays of an open ``.npz`` after checking its members' names and sizes (a member
    is decompressed only up to the size its directory entry states)."""
    if data.zip is None:  # only after close
        raise UnusableAtlasFile("the archive was closed while being read")
    members = {info.filename: info.file_size for info in data.zip.infolist()}
    wanted = {f"{name}.npy" for name in _expected_layout(n, m, 0, 0)}
    if set(members) != wanted:
        raise UnusableAtlasFile(f"holds {sorted(members)}, not the arrays of an atlas file")
    # The largest: flip keys, at most one per grid segment ((n - 1) m + n (m - 1) < 2 n m).
    largest = 2 * n * m * 3 * 8 + _HEADER_BYTES
    too_big = sorted(name for name, size in members.items() if size > largest)
    if too_big:
        raise UnusableAtlasFile(f"{too_big} larger than an atlas of this grid needs")
    return {name: np.asarray(data[name]) for name in data.files}


def read_atlas_file(
    path: Path, *, key: str, x0: npt.NDArray[np.float64], theta0: npt.NDArray[np.float64],
    start_clearance: float,
) -> dict[str, npt.NDArray[np.generic]]:  # fmt: skip
    """The arrays of the atlas file at ``path`` for the atlas ``key`` on the grid ``x0`` x
    ``theta0`` (D, rad) from ``start_clearance`` (D), after every check (module docstring).

    Raises ``FileNotFoundError`` (or ``NotADirectoryError``: the folder is a file) when there
    is no file, :class:`UnusableAtlasFile` (with the reason) when there is one that fails a
    check.
    """
    arrays = _read_arrays(path, x0.size, theta0.size)
    flips = arrays["flip_keys"].shape[0] if arrays["flip_keys"].ndim >= 1 else 0
    layout = _expected_layout(x0.size, theta0.size, flips, len(key))
    for name, (dtype, shape) in layout.items():
        a = arrays[name]
        if a.dtype != dtype or a.shape != shape:
            raise UnusableAtlasFile(
                f"{name} is {a.dtype} {a.shape}, expected {dtype} {shape} for this grid"
            )
    if int(arrays["format"]) != ATLAS_FORMAT:
        raise UnusableAtlasFile(f"format {int(arrays['format'])}, expected {ATLAS_FORMAT}")
    if str(arrays["key"]) != key:
        raise UnusableAtlasFile(f"stored key {arrays['key']} is not the expected {key}")
    stored_sum = str(arrays.pop("checksum"))
    if stored_sum != checksum(arrays):
        raise UnusableAtlasFile("checksum mismatch (the arrays were altered or damaged)")
    if not (np.array_equal(arrays["x0"], x0) and np.array_equal(arrays["theta0"], theta0)):
        raise UnusableAtlasFile("its grid is not the requested one")
    if float(arrays["start_clearance"]) != start_clearance:
        stored = float(arrays["start_clearance"])
        raise UnusableAtlasFile(f"start clearance {stored}, expected {start_clearance}")
    if not bool(np.all(np.isin(arrays["outcomes"], _VALID_OUTCOMES))):
        raise UnusableAtlasFile("outcomes hold values that are not outcome codes")
    return arrays
