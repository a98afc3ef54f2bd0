"""xface_core.bench: the pymunk line of targets.md (timings are never asserted)."""

from __future__ import annotations

import re

import pytest

from xface_core import bench


def test_the_pymunk_line_has_both_map_times_and_their_ratio() -> None:
    pytest.importorskip("pymunk")
    (line,) = bench._pymunk_lines(True, 1)
    assert line.startswith("| 41 x 41 map, X H/D 0.25 r_p 2: xface / pymunk scene")
    assert re.search(r"\| \d+ ms / \d+ s: \d+x \| >= 1000x \|$", line)


def test_without_the_extra_the_line_says_how_to_get_it(monkeypatch: pytest.MonkeyPatch) -> None:
    import builtins

    real_import = builtins.__import__

    def no_crosscheck(name: str, *args: object, **kwargs: object) -> object:
        if name == "crosscheck" or name.endswith(".crosscheck"):
            raise ImportError("no pymunk")
        return real_import(name, *args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(builtins, "__import__", no_crosscheck)
    assert bench._pymunk_lines(True, 1) == [
        "| pymunk scene per 41 x 41 map | not measured: `pip install 'xface[crosscheck]'` | |"
    ]
