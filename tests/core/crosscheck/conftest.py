"""Helpers shared by the cross-check tests."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import fields

import pytest

from xface_core.crosscheck import EngineRun

SameRun = Callable[[EngineRun, EngineRun], bool]


def _same_run(a: EngineRun, b: EngineRun) -> bool:
    """Field by field, NaN equal to NaN (an out-of-reach run has no final height), the types
    too."""
    for f in fields(EngineRun):
        x, y = getattr(a, f.name), getattr(b, f.name)
        if isinstance(x, float) and math.isnan(x):
            if not (isinstance(y, float) and math.isnan(y)):
                return False
        elif x != y or type(x) is not type(y):
            return False
    return True


@pytest.fixture
def same_run() -> SameRun:
    """Are two engine runs the same, field by field (:func:`_same_run`)?"""
    return _same_run
