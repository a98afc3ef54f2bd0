"""Exceptions raised by xface_core.

Every exception derives from :class:`XfaceError`; the value errors also derive from
:class:`ValueError` so callers that already catch the built-in keep working.
"""

from __future__ import annotations

import math
from numbers import Integral, Real

__all__ = [
    "Cancelled",
    "FaceFileError",
    "GeometryError",
    "InputError",
    "XfaceError",
    "XfaceValueError",
    "XfaceWarning",
    "is_integer_in",
]


class XfaceError(Exception):
    """Base class of every error raised by xface_core."""


class Cancelled(XfaceError):
    """A long computation stopped between two of its batches because its caller's ``cancel``
    callback said so (:func:`~xface_core.atlas.build.build_atlas`)."""


class XfaceWarning(UserWarning):
    """Something was worked around that the user should know of (a damaged part of a study
    moved aside, two different rows of one design); the command line prints it as one line."""


class XfaceValueError(XfaceError, ValueError):
    """A parameter is outside its documented range (NaN, infinite, negative size, ...)."""


class GeometryError(XfaceValueError):
    """A face design cannot exist: invalid polygons, overlapping mated parts, bad layers."""


class FaceFileError(GeometryError):
    """A face file cannot be read or does not follow the format (:mod:`xface_core.facefile`)."""


class InputError(XfaceValueError):
    """A query pose cannot be simulated (NaN, infinity, absurd magnitude)."""


def is_integer_in(value: object, lo: int, hi: float = math.inf) -> bool:
    """True for an integer (a numpy integer too, never a bool) with ``lo <= value <= hi``: the
    one rule behind the checks of integer arguments (each raises its own message)."""
    if isinstance(value, bool) or not isinstance(value, Integral):
        return False
    return lo <= int(value) <= hi


def real_number(value: object) -> float | None:
    """``value`` as a float if it is a real number (a numpy number too, never a bool), else
    None: the one rule behind the checks of real arguments (each raises its own message).
    NaN and infinities pass as floats: the callers' range checks refuse them."""
    if isinstance(value, bool) or not isinstance(value, Real):
        return None
    return float(value)


def is_positive_up_to(value: object, hi: float) -> bool:
    """True for a real number (:func:`real_number`) with ``0 < value <= hi`` (never NaN)."""
    number = real_number(value)
    return number is not None and 0.0 < number <= hi
