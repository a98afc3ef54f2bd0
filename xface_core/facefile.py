"""Face files: a connector design in a small, versioned YAML file.

A designer's own connector travels as a file that the CLI (``--face-file``), the ROS node
(``face: custom`` with ``face_file``) and the Python API (:func:`load_face`) all read the
same way, with the same validation as :func:`~xface_core.geometry.custom_face`::

    xface_face: 1                 # format version
    name: my connector            # free text
    width: 0.05                   # the face width D in your length unit (metres on the node)
    mated_distance: 2.5           # pivot-to-pivot distance L when seated, in D
    mirror_symmetric: false       # optional: the design maps onto itself under x -> -x
    layers:                       # one entry per layer; polygons in D, body frames
      - base: [[-0.5, -1.0], [0.5, -1.0], [0.5, 0.25], [-0.5, 0.25]]
        moving: [[-0.5, -1.0], [0.5, -1.0], [0.5, 0.25], [-0.5, 0.25]]

Each part's polygon is in its own body frame: the pivot at the origin, the profile facing
+y, units of the width D (see ``docs/model.md``). Floats are written with Python's shortest
round-trip representation, so a design saved and loaded again is the same design, bit for
bit.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import yaml

from .errors import FaceFileError, GeometryError
from .geometry import FaceDesign, custom_face

__all__ = ["FACE_FILE_VERSION", "load_face", "save_face"]

#: The format version this module writes and reads (the file's ``xface_face`` key).
FACE_FILE_VERSION = 1

_REQUIRED = ("xface_face", "mated_distance", "layers")
_OPTIONAL = ("name", "width", "mirror_symmetric")


def _design_name(design: FaceDesign) -> str:
    if design.kind == "custom":
        return "custom face"
    return f"{design.kind}-Face H/D {design.h_over_d:g} r_p {design.r_p:g}"


def _polygon(points: Any) -> list[list[float]]:
    return [[float(x), float(y)] for x, y in points]


def save_face(design: FaceDesign, path: str | Path, *, name: str | None = None) -> Path:
    """Write ``design`` to a face file at ``path`` (YAML, format :data:`FACE_FILE_VERSION`).

    ``name`` defaults to the design's own (``X-Face H/D 0.25 r_p 2``, ``custom face``).
    Returns the path written.

    Raises
    ------
    FaceFileError
        The file cannot be written (no such directory, no permission, ...).
    """
    doc = {
        "xface_face": FACE_FILE_VERSION,
        "name": _design_name(design) if name is None else str(name),
        "width": float(design.width),
        "mated_distance": float(design.mated_distance),
        "mirror_symmetric": bool(design.mirror_symmetric),
        "layers": [
            {"base": _polygon(b), "moving": _polygon(m)}
            for b, m in zip(design.base_layers, design.moving_layers, strict=True)
        ],
    }
    target = Path(path)
    text = yaml.safe_dump(doc, sort_keys=False, default_flow_style=None, width=100)
    try:
        target.write_text(text, encoding="utf-8")
    except OSError as exc:
        raise FaceFileError(f"cannot write the face file {str(target)!r}: {exc.strerror}") from exc
    return target


def _read(path: Path) -> dict[str, Any]:
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise FaceFileError(f"cannot read the face file {str(path)!r}: {exc.strerror}") from exc
    except UnicodeDecodeError as exc:
        raise FaceFileError(f"the face file {str(path)!r} is not UTF-8 text") from exc
    try:
        doc = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise FaceFileError(f"the face file {str(path)!r} is not valid YAML: {exc}") from exc
    if not isinstance(doc, dict):
        raise FaceFileError(f"the face file {str(path)!r} must be a YAML mapping (key: value)")
    return doc


def _number(doc: dict[str, Any], key: str, default: float | None = None) -> float:
    value = doc.get(key, default)
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise FaceFileError(f"{key} must be a number, got {value!r}")
    return float(value)


def _layers(doc: dict[str, Any]) -> tuple[list[Any], list[Any]]:
    layers = doc["layers"]
    if not isinstance(layers, list) or not layers:
        raise FaceFileError("layers must be a non-empty list of {base: ..., moving: ...}")
    base, moving = [], []
    for i, layer in enumerate(layers):
        if not isinstance(layer, dict) or set(layer) != {"base", "moving"}:
            raise FaceFileError(f"layer {i} must have exactly the keys base and moving")
        base.append(layer["base"])
        moving.append(layer["moving"])
    return base, moving


def load_face(path: str | Path) -> FaceDesign:
    """Read a face file (see the module's docstring for the format).

    The polygons go through :func:`~xface_core.geometry.custom_face`, so a file is checked
    exactly like a design built in Python.

    Raises
    ------
    FaceFileError
        The file cannot be read, is not YAML, has another format version, misses a key or has
        one this version does not know.
    GeometryError
        The design cannot exist (a polygon not simple, the mated parts overlapping, ...).
        :class:`FaceFileError` is a :class:`GeometryError` too: catching that catches both.
    """
    source = Path(path)
    doc = _read(source)
    missing = [key for key in _REQUIRED if key not in doc]
    if missing:
        raise FaceFileError(f"the face file {str(source)!r} misses {', '.join(missing)}")
    unknown = sorted(set(doc) - set(_REQUIRED) - set(_OPTIONAL))
    if unknown:
        raise FaceFileError(
            f"the face file {str(source)!r} has unknown keys {', '.join(map(str, unknown))} "
            f"(format {FACE_FILE_VERSION} knows {', '.join(_REQUIRED + _OPTIONAL)})"
        )
    if doc["xface_face"] != FACE_FILE_VERSION:
        raise FaceFileError(
            f"the face file {str(source)!r} has format version {doc['xface_face']!r}; this "
            f"xface reads version {FACE_FILE_VERSION}"
        )
    mirror = doc.get("mirror_symmetric", False)
    if not isinstance(mirror, bool):
        raise FaceFileError(f"mirror_symmetric must be true or false, got {mirror!r}")
    width = _number(doc, "width", 1.0)
    mated = _number(doc, "mated_distance")
    if not (math.isfinite(width) and math.isfinite(mated)):
        raise FaceFileError("width and mated_distance must be finite")
    base, moving = _layers(doc)
    try:
        return custom_face(base, moving, mated_distance=mated, width=width, mirror_symmetric=mirror)
    except FaceFileError:
        raise
    except GeometryError as exc:
        raise GeometryError(f"the face file {str(source)!r}: {exc}") from exc
