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
import os
import re
import reprlib
import stat
from dataclasses import replace
from pathlib import Path
from typing import Any

import yaml

from .errors import FaceFileError, XfaceValueError, real_number
from .geometry import FaceDesign, custom_face

__all__ = [
    "FACE_FILE_VERSION",
    "MAX_FACE_FILE_BYTES",
    "MAX_NESTING_DEPTH",
    "MAX_NUMBER_CHARS",
    "MAX_YAML_VALUES",
    "load_face",
    "save_face",
]

#: The format version this module writes and reads (the file's ``xface_face`` key).
FACE_FILE_VERSION = 1

_REQUIRED = ("xface_face", "mated_distance", "layers")
_OPTIONAL = ("name", "width", "mirror_symmetric")


def _design_name(design: FaceDesign) -> str:
    if design.kind == "custom" or design.name:
        return design.display_name
    return f"{design.kind}-Face H/D {design.h_over_d:g} r_p {design.r_p:g}"


def _polygon(points: Any) -> list[list[float]]:
    return [[float(x), float(y)] for x, y in points]


def save_face(design: FaceDesign, path: str | Path, *, name: str | None = None) -> Path:
    """Write ``design`` to a face file at ``path`` (YAML, format :data:`FACE_FILE_VERSION`).

    ``name`` defaults to the design's own (its ``name``, a loaded file's; else
    ``X-Face H/D 0.25 r_p 2``, ``custom face``).
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


#: Largest face file read, in bytes (1 MiB). A design at the engine's limit of
#: :data:`~xface_core.geometry.MAX_CONTACT_PAIRS` (two 500-vertex outlines) takes about 50 KB;
#: the size is checked before reading, and at most this many bytes plus one are read.
MAX_FACE_FILE_BYTES = 1024 * 1024

#: Deepest nesting of YAML collections and values: a face file needs 6 (the file, layers,
#: a layer, a polygon, a vertex, a number). Deeper nesting is refused while it is read,
#: long before Python's recursion limit.
MAX_NESTING_DEPTH = 12

#: Most YAML values (collections and scalars) a face file may make, counting each alias
#: (``*name``) as the whole value it repeats: about 66 000 vertices, far more than
#: :data:`~xface_core.geometry.MAX_CONTACT_PAIRS` lets a design have, and a bound on the
#: work a "billion laughs" file of aliases of aliases can cause.
MAX_YAML_VALUES = 200_000

#: Longest number, in characters: a float written by :func:`save_face` (Python's shortest
#: round trip) takes at most 24. Longer ones (a 5 000-digit integer) are refused before
#: Python converts them.
MAX_NUMBER_CHARS = 40

_MERGE_TAG = "tag:yaml.org,2002:merge"


#: Where PyYAML says a value starts (its Python or its C reader's Mark, both with line and
#: column counted from 0), or None.
_Mark = Any


def _where(mark: _Mark) -> str:
    return "" if mark is None else f", line {mark.line + 1}, column {mark.column + 1}"


class _FaceFileLoader(yaml.SafeLoader):
    """PyYAML's safe loader with the face file's limits on nesting, values, aliases,
    numbers and duplicate keys; every refusal is a :class:`FaceFileError` naming the file,
    the place and the limit.

    Aliases are allowed (``yaml.safe_dump`` writes them whenever one list object appears
    twice, for example the same polygon for the base and the moving part) but each counts as
    the whole value it repeats, so aliases of aliases cannot multiply the work.
    """

    def __init__(self, text: str, source: str) -> None:
        super().__init__(text)
        self.source = source
        self.depth = 0
        # Per composed node (by id): (values in it counting aliases expanded, its height).
        self.extent: dict[int, tuple[int, int]] = {}

    def refuse(self, what: str, mark: _Mark) -> FaceFileError:
        return FaceFileError(f"the face file {self.source!r}{_where(mark)}: {what}")

    def _next_mark(self) -> _Mark:
        event: yaml.Event = self.peek_event()  # type: ignore[no-untyped-call]  # untyped stub
        return event.start_mark

    def compose_node(self, parent: yaml.Node | None, index: int) -> yaml.Node | None:
        if self.check_event(yaml.AliasEvent):
            mark = self._next_mark()
            node = super().compose_node(parent, index)
            if node is None or id(node) not in self.extent:  # an alias inside its own anchor
                raise self.refuse("a YAML alias refers to a value that contains it", mark)
            return node
        self.depth += 1
        try:
            if self.depth > MAX_NESTING_DEPTH:
                mark = self._next_mark()
                raise self.refuse(
                    f"nesting deeper than MAX_NESTING_DEPTH = {MAX_NESTING_DEPTH}", mark
                )
            node = super().compose_node(parent, index)
        finally:
            self.depth -= 1
        if node is not None:
            self._measure(node)
        return node

    def _measure(self, node: yaml.Node) -> None:
        """Record the node's size and height, aliases expanded, and refuse past the limits."""
        if isinstance(node, yaml.SequenceNode):
            children = list(node.value)
        elif isinstance(node, yaml.MappingNode):
            children = [child for pair in node.value for child in pair]
        else:
            children = []
        sizes = [self.extent[id(child)] for child in children]
        size = 1 + sum(n for n, _ in sizes)
        height = 1 + max((h for _, h in sizes), default=0)
        if size > MAX_YAML_VALUES:
            raise self.refuse(
                f"more than MAX_YAML_VALUES = {MAX_YAML_VALUES} values (aliases count as what "
                "they repeat)",
                node.start_mark,
            )
        if height > MAX_NESTING_DEPTH:
            raise self.refuse(
                f"nesting deeper than MAX_NESTING_DEPTH = {MAX_NESTING_DEPTH} (aliases "
                "count as what they repeat)",
                node.start_mark,
            )
        self.extent[id(node)] = (size, height)

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        seen: dict[Any, yaml.Node] = {}
        for key_node, _ in node.value:
            if key_node.tag == _MERGE_TAG:
                continue
            key = self.construct_object(key_node, deep=deep)
            try:
                first = seen.setdefault(key, key_node)
            except TypeError:  # an unhashable key: PyYAML's own message follows
                continue
            if first is not key_node:
                raise self.refuse(
                    f"duplicate key {reprlib.repr(key)} (first at line "
                    f"{first.start_mark.line + 1})",
                    key_node.start_mark,
                )
        return super().construct_mapping(node, deep=deep)

    def _short_number(self, node: yaml.ScalarNode) -> None:
        if len(node.value) > MAX_NUMBER_CHARS:
            raise self.refuse(
                f"a number written with {len(node.value)} characters (MAX_NUMBER_CHARS = "
                f"{MAX_NUMBER_CHARS})",
                node.start_mark,
            )

    def construct_yaml_int(self, node: yaml.ScalarNode) -> int:
        self._short_number(node)
        return int(super().construct_yaml_int(node))

    def construct_yaml_float(self, node: yaml.ScalarNode) -> float:
        self._short_number(node)
        return float(super().construct_yaml_float(node))

    def construct_yaml_timestamp(self, node: yaml.ScalarNode) -> Any:
        try:
            return super().construct_yaml_timestamp(node)
        except (ValueError, OverflowError) as exc:  # 2026-13-45 matches YAML's date pattern
            raise self.refuse(f"not a valid date ({exc})", node.start_mark) from None


# YAML 1.2's floats: PyYAML (YAML 1.1) reads 1e-3 and 2.5e3 as text (it wants a dot and a
# signed exponent); a face file means the number.
_FaceFileLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?$"),
    list("-+0123456789."),
)
_FaceFileLoader.add_constructor("tag:yaml.org,2002:int", _FaceFileLoader.construct_yaml_int)
_FaceFileLoader.add_constructor("tag:yaml.org,2002:float", _FaceFileLoader.construct_yaml_float)
_FaceFileLoader.add_constructor(
    "tag:yaml.org,2002:timestamp", _FaceFileLoader.construct_yaml_timestamp
)


def _file_kind(mode: int) -> str:
    """What a non-regular file is, for the refusal's message."""
    kinds = (
        (stat.S_ISDIR, "a directory"),
        (stat.S_ISFIFO, "a FIFO (named pipe)"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISSOCK, "a socket"),
    )
    return next((kind for test, kind in kinds if test(mode)), "a special file")


def _read_bytes(path: Path) -> bytes:
    """The file's bytes: only a regular file (a FIFO, a device or a directory is refused
    before it is opened, so nothing blocks), at most :data:`MAX_FACE_FILE_BYTES`."""
    name = str(path)
    try:
        info = os.stat(path)
        if not stat.S_ISREG(info.st_mode):
            raise FaceFileError(
                f"the face file {name!r} is {_file_kind(info.st_mode)}, not a regular file: "
                "only regular files are read (a FIFO or a device could block or never end)"
            )
        if info.st_size > MAX_FACE_FILE_BYTES:
            raise FaceFileError(
                f"the face file {name!r} has {info.st_size} bytes, more than "
                f"MAX_FACE_FILE_BYTES = {MAX_FACE_FILE_BYTES}"
            )
        # O_NONBLOCK: should the path become a FIFO between stat and open, opening it does not
        # wait for a writer; fstat then refuses it.
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0))
        with os.fdopen(fd, "rb") as stream:
            if not stat.S_ISREG(os.fstat(stream.fileno()).st_mode):
                raise FaceFileError(f"the face file {name!r} is not a regular file")
            data = stream.read(MAX_FACE_FILE_BYTES + 1)
    except OSError as exc:
        raise FaceFileError(f"cannot read the face file {name!r}: {exc.strerror}") from exc
    if len(data) > MAX_FACE_FILE_BYTES:  # it grew after the stat
        raise FaceFileError(
            f"the face file {name!r} has more than MAX_FACE_FILE_BYTES = "
            f"{MAX_FACE_FILE_BYTES} bytes"
        )
    return data


def _read(path: Path) -> dict[str, Any]:
    data = _read_bytes(path)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise FaceFileError(
            f"the face file {str(path)!r} is not UTF-8 text (byte {exc.start})"
        ) from exc
    try:
        loader = _FaceFileLoader(text, str(path))  # checks the characters at once
        try:
            doc = loader.get_single_data()
        finally:
            loader.dispose()
    except yaml.reader.ReaderError as exc:  # a control character, before any parsing
        line = text.count("\n", 0, exc.position) + 1
        raise FaceFileError(
            f"the face file {str(path)!r} is not valid YAML, line {line}: the character "
            f"#x{exc.character:04x} is not allowed"
        ) from None
    except yaml.MarkedYAMLError as exc:
        # One line: where, and what (PyYAML's own message quotes the text over several).
        mark = exc.problem_mark or exc.context_mark
        what = exc.problem or exc.context or "not valid YAML"
        raise FaceFileError(
            f"the face file {str(path)!r} is not valid YAML{_where(mark)}: {what}"
        ) from None
    except yaml.YAMLError as exc:
        what = " ".join(str(exc).split())
        raise FaceFileError(f"the face file {str(path)!r} is not valid YAML: {what}") from None
    if not isinstance(doc, dict):
        raise FaceFileError(f"the face file {str(path)!r} must be a YAML mapping (key: value)")
    return doc


def _is_number(value: object) -> bool:
    return real_number(value) is not None


def _number(doc: dict[str, Any], key: str, default: float | None = None) -> float:
    value = doc.get(key, default)
    number = real_number(value)
    if number is None:
        raise FaceFileError(f"{key} must be a number, got {reprlib.repr(value)}")
    return number


def _vertices(points: Any, name: str) -> list[tuple[float, float]]:
    """A polygon as the file writes it: a list of [x, y] number pairs (checked here, so that
    strings, booleans or nested lists never reach numpy, which would take "1e3" for 1000)."""
    if not isinstance(points, list):
        raise FaceFileError(f"{name} must be a list of [x, y] vertices, got {reprlib.repr(points)}")
    for k, point in enumerate(points):
        if not (isinstance(point, list) and len(point) == 2 and all(map(_is_number, point))):
            raise FaceFileError(
                f"{name}: vertex {k} must be a pair of numbers [x, y], got {reprlib.repr(point)}"
            )
    return [(float(x), float(y)) for x, y in points]


def _layers(doc: dict[str, Any]) -> tuple[list[Any], list[Any]]:
    layers = doc["layers"]
    if not isinstance(layers, list) or not layers:
        raise FaceFileError("layers must be a non-empty list of {base: ..., moving: ...}")
    base, moving = [], []
    for i, layer in enumerate(layers):
        if not isinstance(layer, dict) or set(layer) != {"base", "moving"}:
            raise FaceFileError(f"layer {i} must have exactly the keys base and moving")
        base.append(_vertices(layer["base"], f"base layer {i}"))
        moving.append(_vertices(layer["moving"], f"moving layer {i}"))
    return base, moving


def _design_from(doc: dict[str, Any]) -> FaceDesign:
    """The design a parsed face file describes; the reason (without the file's name) if not."""
    missing = [key for key in _REQUIRED if key not in doc]
    if missing:
        raise FaceFileError(f"misses {', '.join(missing)}")
    unknown = sorted(map(str, set(doc) - set(_REQUIRED) - set(_OPTIONAL)))
    if unknown:
        raise FaceFileError(
            f"has unknown keys {reprlib.repr(', '.join(unknown))[1:-1]} "
            f"(format {FACE_FILE_VERSION} knows {', '.join(_REQUIRED + _OPTIONAL)})"
        )
    version = doc["xface_face"]
    if isinstance(version, bool) or version != FACE_FILE_VERSION:
        raise FaceFileError(
            f"has format version {reprlib.repr(version)}; this xface reads version "
            f"{FACE_FILE_VERSION}"
        )
    mirror = doc.get("mirror_symmetric", False)
    if not isinstance(mirror, bool):
        raise FaceFileError(f"mirror_symmetric must be true or false, got {reprlib.repr(mirror)}")
    width = _number(doc, "width", 1.0)
    mated = _number(doc, "mated_distance")
    if not (math.isfinite(width) and math.isfinite(mated)):
        raise FaceFileError("width and mated_distance must be finite")
    base, moving = _layers(doc)
    # custom_face checks the geometry, the coordinates' range and the mirror_symmetric claim.
    design = custom_face(base, moving, mated_distance=mated, width=width, mirror_symmetric=mirror)
    return replace(design, name=_file_name(doc.get("name")))


def _file_name(value: object) -> str | None:
    """The ``name:`` of a file as text names it: on one line (YAML keeps a block's line
    breaks), None when absent or blank (the design is then called by its file's name)."""
    if value is None:
        return None
    words = str(value).split()
    return " ".join(words) if words else None


def load_face(path: str | Path) -> FaceDesign:
    """Read a face file (see the module's docstring for the format, ``docs/facefile.md`` for
    the limits).

    The file is read with limits on what it may make the reader do (its size, nesting,
    number of values, aliases, digits per number; only a regular file is opened), and the
    polygons go through :func:`~xface_core.geometry.custom_face`, so a file is checked exactly
    like a design built in Python, its ``mirror_symmetric`` claim included.

    Raises
    ------
    FaceFileError
        Whatever is wrong, naming the file: it cannot be read, is not a regular file, passes
        a limit, is not YAML or has a duplicate key, has another format version, misses a key
        or has one this version does not know, or describes a design that cannot exist (a
        polygon not simple, the mated parts overlapping, a false ``mirror_symmetric``, ...).
        :class:`FaceFileError` is a :class:`GeometryError`: catching that catches it.
    """
    source = Path(path)
    doc = _read(source)
    try:
        design = _design_from(doc)
    except XfaceValueError as exc:  # GeometryError and FaceFileError included
        raise FaceFileError(f"the face file {str(source)!r}: {exc}") from exc
    # A file without a name is called by its own: two unnamed files stay apart in text.
    return design if design.name else replace(design, name=source.stem or str(source))
