"""Design spaces: the product of faces, H/D, r_p, friction and damping ratio a study sweeps.

A design study asks "which face, which H/D and r_p, for my friction?": every combination of
the listed values is one *design point*, and each point is simulated over the same pose grid
(see :mod:`xface_core.study.run`). Faces are the built-in letters X, V and S, or the names of
*families*: Python callables ``family(h_over_d, r_p) -> FaceDesign`` that build a
user-defined face (for example with :func:`~xface_core.geometry.custom_face`) from the two
parameters, whatever they mean for that family. A *face file* (:class:`FileFace`, the
CLI's ``--face-file``) is a fixed design: it adds one point per friction and damping ratio,
H/D and r_p do not apply to it (None in its points, null in the table), and its points carry
its name as the face and its geometry's digest (``face_digest``), so that two files of one
name stay apart. Lengths are in widths D, angles in radians.
"""

from __future__ import annotations

import hashlib
import itertools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

from xface_core.errors import XfaceError, XfaceValueError
from xface_core.geometry import FaceDesign, make_face
from xface_core.physics import Physics

__all__ = [
    "BUILT_IN_FACES",
    "MAX_DESIGNS",
    "DesignPoint",
    "DesignSpace",
    "FaceFamily",
    "FileFace",
    "face_digest",
    "parse_face_list",
    "parse_number_list",
]

#: A family of user-defined faces: (H/D, r_p) -> design (units of D; the width is ignored).
FaceFamily = Callable[[float, float], FaceDesign]

#: The faces every study knows by their letter.
BUILT_IN_FACES = ("X", "V", "S")

#: Most designs in one study: each is validated (built) up front in the calling process, and
#: at 1e5 designs of a 41 x 41 grid the study is already 1.7e8 runs (days on one machine).
MAX_DESIGNS = 100_000


class DesignPoint(NamedTuple):
    """One design of a study: the face (a letter, a family's name or a face file's name) and
    its parameters.

    The tuple itself is the design's key in a study table: two points are the same design
    exactly when all six fields are equal.
    """

    face: str
    h_over_d: float | None
    """Profile height over width H/D (a family's first parameter; None for a face file)."""
    r_p: float | None
    """Pivot to profile base, in widths D (a family's second parameter; None for a file)."""
    friction: float
    """Coulomb friction coefficient mu."""
    damping_ratio: float
    """Rotational damping c_B / c_M (inf: the base does not turn)."""
    face_digest: str = ""
    """A face file's :func:`face_digest` (its geometry); empty for the other faces."""

    @property
    def physics(self) -> Physics:
        """The validated physics of this design (default solver settings)."""
        return Physics(damping_ratio=self.damping_ratio, friction=self.friction)


#: Hex digits of a face file's digest kept in a study table (64 bits: two different
#: geometries collide with probability 2**-64 per pair).
FACE_DIGEST_CHARS = 16


def face_digest(design: FaceDesign) -> str:
    """The first :data:`FACE_DIGEST_CHARS` hex digits of the SHA-256 of a design's geometry
    (its polygons, mated distance and symmetry claim, exact floats): what tells two face
    files apart in a study table. Neither the name, the width (a study runs in D) nor the
    file's path or formatting changes it.

    Examples
    --------
    >>> from xface_core.geometry import x_face
    >>> face_digest(x_face(0.25, 2.0)) == face_digest(x_face(0.25, 2.0, width=0.05))
    True
    >>> face_digest(x_face(0.25, 2.0)) == face_digest(x_face(0.25, 1.0))
    False
    """
    text = repr((design.cache_key, design.mirror_symmetric))
    return hashlib.sha256(text.encode()).hexdigest()[:FACE_DIGEST_CHARS]


@dataclass(frozen=True)
class FileFace:
    """A face file in a design space: one fixed design (read by
    :func:`~xface_core.facefile.load_face`), named by its ``name:`` and told apart by the
    digest of its geometry."""

    path: str
    design: FaceDesign

    @property
    def name(self) -> str:
        """The file's ``name:`` (or its file name): the table's ``face``."""
        return self.design.display_name

    @property
    def digest(self) -> str:
        """:func:`face_digest` of the design: the table's ``face_digest``."""
        return face_digest(self.design)


@dataclass(frozen=True)
class DesignSpace:
    """The product ``faces x h_over_d x r_p x friction x damping_ratio``, and each of
    ``face_files`` (fixed designs) at every ``friction x damping_ratio``.

    Examples
    --------
    >>> space = DesignSpace(faces=("X", "V"), h_over_d=(0.25, 0.5), r_p=(1.0, 2.0))
    >>> len(space), space.points()[0]  # doctest: +NORMALIZE_WHITESPACE
    (8, DesignPoint(face='X', h_over_d=0.25, r_p=1.0, friction=0.0, damping_ratio=1.0,
                    face_digest=''))
    >>> DesignSpace(faces=("Q",), h_over_d=(1.0,), r_p=(1.0,)).points()
    Traceback (most recent call last):
    ...
    xface_core.errors.XfaceValueError: face 'Q' is neither X, V, S nor a family of this space
    """

    faces: Sequence[str]
    h_over_d: Sequence[float]
    r_p: Sequence[float]
    friction: Sequence[float] = (0.0,)
    damping_ratio: Sequence[float] = (1.0,)
    families: Mapping[str, FaceFamily] = field(default_factory=dict)
    face_files: Sequence[FileFace] = ()

    def __len__(self) -> int:
        physics = len(self.friction) * len(self.damping_ratio)
        shaped = len(self.faces) * len(self.h_over_d) * len(self.r_p)
        return (shaped + len(self.face_files)) * physics

    def points(self) -> list[DesignPoint]:
        """Every design point, faces outermost, damping ratio innermost (validated); the face
        files' points after the others, in the order of ``face_files``."""
        axes: dict[str, Sequence[str] | Sequence[float]] = {
            "friction": self.friction,
            "damping_ratio": self.damping_ratio,
        }
        if self.faces or not self.face_files:  # a study of face files alone needs no H/D
            axes = {"faces": self.faces, "h_over_d": self.h_over_d, "r_p": self.r_p, **axes}
        for name, values in axes.items():
            if len(values) == 0:
                raise XfaceValueError(f"the design space is empty: no {name} values")
            if len(set(values)) != len(values):
                raise XfaceValueError(f"{name} lists a value twice: {list(values)}")
        self._check_face_files()
        if len(self) > MAX_DESIGNS:
            raise XfaceValueError(
                f"{len(self)} designs is more than {MAX_DESIGNS} in one study: split it"
            )
        for face in self.faces:
            if face not in BUILT_IN_FACES and face not in self.families:
                raise XfaceValueError(
                    f"face {face!r} is neither X, V, S nor a family of this space"
                )
        for mu, d in itertools.product(self.friction, self.damping_ratio):
            Physics(damping_ratio=d, friction=mu)  # raises for a value out of range
        shaped = [
            DesignPoint(f, float(h), float(rp), float(mu), float(d))
            for f, h, rp, mu, d in itertools.product(
                self.faces, self.h_over_d, self.r_p, self.friction, self.damping_ratio
            )
        ]
        return shaped + [
            DesignPoint(file.name, None, None, float(mu), float(d), file.digest)
            for file, mu, d in itertools.product(self.face_files, self.friction, self.damping_ratio)
        ]

    def _check_face_files(self) -> None:
        """Each face file once: the same geometry under the same name is one design."""
        seen: dict[tuple[str, str], str] = {}
        for file in self.face_files:
            key = (file.name, file.digest)
            if key in seen:
                raise XfaceValueError(
                    f"the face files {seen[key]!r} and {file.path!r} hold the same design "
                    f"under the same name {file.name!r}: give it once"
                )
            seen[key] = file.path

    def design(self, point: DesignPoint) -> FaceDesign:
        """The face of ``point`` (built-in, from its family or a face file), validated."""
        if point.face_digest:
            for file in self.face_files:
                if (file.name, file.digest) == (point.face, point.face_digest):
                    return file.design
            raise XfaceValueError(
                f"no face file of this space is {point.face!r} ({point.face_digest})"
            )
        if point.h_over_d is None or point.r_p is None:
            raise XfaceValueError(f"face {point.face!r} needs H/D and r_p")
        family = self.families.get(point.face)
        if family is None:
            return make_face(point.face, point.h_over_d, point.r_p)
        try:
            design = family(point.h_over_d, point.r_p)
        except XfaceError as exc:
            raise XfaceValueError(f"family {point.face!r} at {point[1:3]}: {exc}") from None
        if not isinstance(design, FaceDesign):
            raise XfaceValueError(
                f"family {point.face!r} must return a FaceDesign, got {type(design).__name__}"
            )
        return design


def parse_number_list(text: str, option: str) -> tuple[float, ...]:
    """A comma list of numbers (``"0.25,0.5"``), each finite or ``inf``.

    Examples
    --------
    >>> parse_number_list("0.25, 0.5,1", "--h-over-d")
    (0.25, 0.5, 1.0)
    >>> parse_number_list("0.25,,1", "--h-over-d")
    Traceback (most recent call last):
    ...
    xface_core.errors.XfaceValueError: --h-over-d: '0.25,,1' is not a comma list of numbers
    """
    items = [s.strip() for s in text.split(",")]
    try:
        values = tuple(float(s) for s in items)
    except ValueError:
        values = ()
    if not values or any(math.isnan(v) or v == -math.inf for v in values):
        raise XfaceValueError(f"{option}: {text!r} is not a comma list of numbers")
    return values


def parse_face_list(text: str) -> tuple[str, ...]:
    """A comma list of built-in face letters (``"X,V"``, case-insensitive); empty text, none.

    Examples
    --------
    >>> parse_face_list("x,V")
    ('X', 'V')
    """
    if not text.strip():
        return ()
    faces = tuple(s.strip().upper() for s in text.split(","))
    bad = [f for f in faces if f not in BUILT_IN_FACES]
    if bad:
        raise XfaceValueError(f"--face: {text!r} is not a comma list of X, V and S")
    return faces
