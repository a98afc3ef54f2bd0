"""Face files a hostile (or careless) user wrote: every one is a FaceFileError naming the
file and the limit, never a traceback, a hang or gigabytes of memory (docs/facefile.md)."""

from __future__ import annotations

import os
import re
import tempfile
import textwrap
import threading
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import xface_core as xf
from xface_core import FaceFileError
from xface_core.facefile import (
    MAX_FACE_FILE_BYTES,
    MAX_NESTING_DEPTH,
    MAX_NUMBER_CHARS,
    MAX_YAML_VALUES,
)
from xface_core.geometry import MAX_CUSTOM_COORDINATE, MAX_WIDTH, is_mirror_symmetric

# An asymmetric single ramp with a step (scripts/evidence/golden_maps.py): not mirror-symmetric.
LOPSIDED = xf.custom_face(
    [[(-0.5, -1.0), (0.5, -1.0), (0.5, 0.4), (0.1, 0.4), (-0.5, 0.0)]],
    [[(-0.5, -1.0), (0.5, -1.0), (0.5, 0.4), (-0.1, 0.0), (-0.5, 0.0)]],
    mated_distance=1.5,
    width=0.04,
)


def _saved_text(design: xf.FaceDesign) -> str:
    with tempfile.TemporaryDirectory() as tmp:
        return xf.save_face(design, Path(tmp) / "face.yaml").read_text(encoding="utf-8")


X_TEXT = _saved_text(xf.x_face(0.25, 2.0, width=0.05))
VALID_TEXTS = [
    X_TEXT,
    _saved_text(xf.v_face(0.5, 1.0)),
    _saved_text(xf.s_face(0.32988, 2.0)),
    _saved_text(LOPSIDED),
]


def _file(tmp_path: Path, text: str | bytes, name: str = "face.yaml") -> Path:
    path = tmp_path / name
    if isinstance(text, str):
        text = text.encode("utf-8")
    path.write_bytes(text)
    return path


def _refused(path: Path, *phrases: str) -> str:
    """Load ``path``, expect a FaceFileError naming the file and every phrase; its message."""
    with pytest.raises(FaceFileError) as caught:
        xf.load_face(path)
    message = str(caught.value)
    assert str(path) in message
    for phrase in phrases:
        assert phrase in message
    return message


def test_a_width_written_with_thousands_of_digits_is_refused_naming_the_limit(
    tmp_path: Path,
) -> None:
    # Before: ValueError (Python's 4300-digit limit on int()) out of the YAML reader.
    path = _file(tmp_path, X_TEXT.replace("width: 0.05", "width: " + "1" * 5000))
    _refused(path, "line 3, column 8", "5000 characters", f"MAX_NUMBER_CHARS = {MAX_NUMBER_CHARS}")


def test_a_vertex_written_with_hundreds_of_digits_is_refused_naming_the_limit(
    tmp_path: Path,
) -> None:
    # Before: OverflowError (an int too large for a float) out of numpy.
    path = _file(tmp_path, X_TEXT.replace("[0.5, 2.25]", "[0.5, " + "9" * 400 + "]", 1))
    _refused(path, "400 characters", "MAX_NUMBER_CHARS")


def test_deeply_nested_lists_are_refused_before_python_recursion(tmp_path: Path) -> None:
    # Before: RecursionError out of PyYAML's composer.
    deep = "[" * 10_000 + "]" * 10_000
    path = _file(tmp_path, X_TEXT.replace("name: ", f"name: {deep}\nold_name: "))
    _refused(path, f"MAX_NESTING_DEPTH = {MAX_NESTING_DEPTH}")


def test_a_vertex_beyond_the_coordinate_bound_is_refused(tmp_path: Path) -> None:
    # Before: accepted, then predict raised ZeroDivisionError (squared lengths overflow).
    path = _file(tmp_path, X_TEXT.replace("[0.5, 2.25]", "[1.0e+200, 1.0e+154]", 1))
    _refused(path, "base layer 0", f"beyond +-{MAX_CUSTOM_COORDINATE:g} D")


def test_a_character_device_is_refused_without_reading_it(tmp_path: Path) -> None:
    # Before: /dev/zero was read until MemoryError.
    _refused(Path("/dev/zero"), "a character device, not a regular file")


def test_a_directory_is_refused_as_not_a_regular_file(tmp_path: Path) -> None:
    _refused(tmp_path, "a directory, not a regular file")


def test_a_fifo_is_refused_without_blocking(tmp_path: Path) -> None:
    # Before: opening the FIFO waited for a writer forever.
    fifo = tmp_path / "face.yaml"
    os.mkfifo(fifo)
    outcome: list[BaseException | xf.FaceDesign] = []

    def load() -> None:
        try:
            outcome.append(xf.load_face(fifo))
        except BaseException as exc:  # handed to the test's thread below
            outcome.append(exc)

    reader = threading.Thread(target=load, daemon=True)
    reader.start()
    reader.join(timeout=60.0)  # a hang detector, not a timing: the refusal takes microseconds
    if reader.is_alive():
        # Unblock the reader (a writer that closes at once gives it end of file), then fail.
        os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK))
        reader.join(timeout=10.0)
        pytest.fail("load_face blocked on a FIFO")
    assert isinstance(outcome[0], FaceFileError)
    assert "a FIFO (named pipe), not a regular file" in str(outcome[0])


def test_a_file_over_the_size_limit_is_refused_before_it_is_read(tmp_path: Path) -> None:
    padding = "#" * (MAX_FACE_FILE_BYTES - len(X_TEXT)) + "\n"
    path = _file(tmp_path, X_TEXT + padding)
    _refused(path, f"{MAX_FACE_FILE_BYTES + 1} bytes", "MAX_FACE_FILE_BYTES")


def test_a_file_of_exactly_the_size_limit_loads(tmp_path: Path) -> None:
    padding = "#" * (MAX_FACE_FILE_BYTES - len(X_TEXT) - 1) + "\n"
    path = _file(tmp_path, X_TEXT + padding)
    assert path.stat().st_size == MAX_FACE_FILE_BYTES
    assert xf.load_face(path).mated_distance == 4.25


BILLION_LAUGHS = "\n".join(
    [
        'a: &a ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]',
        *(
            f"{c}: &{c} [{', '.join([f'*{p}'] * 9)}]"
            for p, c in zip("abcdefgh", "bcdefghi", strict=True)
        ),
    ]
)


def test_a_yaml_alias_bomb_is_refused_after_a_bounded_count(tmp_path: Path) -> None:
    # Before: PyYAML built the shared lists cheaply, then turning the polygon into an array
    # expanded 9**9 values (gigabytes). Here the free-text name holds the bomb.
    bomb = textwrap.indent(BILLION_LAUGHS, "  ")
    text = X_TEXT.replace("name: X-Face H/D 0.25 r_p 2", f"name:\n{bomb}")
    first_base = "- base:\n  - [0.5, -1.0]\n  - [0.5, 2.25]\n  - [-0.5, 2.0]\n  - [-0.5, -1.0]\n"
    assert first_base in text
    text = text.replace(first_base, "- base: *i\n", 1)
    path = _file(tmp_path, text)
    assert path.stat().st_size < 1000
    _refused(path, f"MAX_YAML_VALUES = {MAX_YAML_VALUES}", "aliases count as what they repeat")


def test_a_yaml_alias_inside_its_own_anchor_is_refused(tmp_path: Path) -> None:
    path = _file(tmp_path, X_TEXT.replace("name: ", "name: &loop [*loop]\nold_name: "))
    _refused(path, "line 2, column 14", "alias refers to a value that contains it")


def test_a_false_mirror_symmetry_claim_in_a_file_is_refused(tmp_path: Path) -> None:
    # Before: taken on trust, and the maps copied wrong outcomes onto their mirror halves.
    text = _saved_text(LOPSIDED).replace("mirror_symmetric: false", "mirror_symmetric: true")
    _refused(_file(tmp_path, text), "mirror_symmetric is claimed but the design is not")


def test_a_duplicate_key_is_refused_naming_both_lines(tmp_path: Path) -> None:
    # Before: the last width silently won.
    path = _file(tmp_path, X_TEXT + "width: 3.0\n")
    _refused(path, "duplicate key 'width' (first at line 3)", "line 27, column 1")


def test_a_duplicate_key_inside_a_layer_is_refused(tmp_path: Path) -> None:
    text = X_TEXT.replace("  moving:\n", "  base: [[0, 0], [1, 0], [0, 1]]\n  moving:\n", 1)
    _refused(_file(tmp_path, text), "duplicate key 'base'")


def test_a_yaml_syntax_error_is_one_line_naming_the_file_line_and_column(
    tmp_path: Path,
) -> None:
    # Before: PyYAML's eight-line message with the quoted text.
    path = _file(tmp_path, "xface_face: 1\nlayers: [unclosed\n")
    message = _refused(path, "is not valid YAML, line 3, column 1:", "expected ','")
    assert "\n" not in message


def test_an_impossible_design_in_a_file_is_a_face_file_error_naming_the_file(
    tmp_path: Path,
) -> None:
    # Before: a GeometryError that is not a FaceFileError, so "FaceFileError" missed it.
    path = _file(tmp_path, X_TEXT.replace("mated_distance: 4.25", "mated_distance: 1.0"))
    _refused(path, "the mated parts overlap")


@pytest.mark.parametrize(
    ("replace", "by", "phrase"),
    [
        ("name: ", "name: 2026-13-45\nold_name: ", "not a valid date"),
        ("name: ", "1: one\ncolour: red\nname: ", "unknown keys 1, colour"),
        ("[0.5, 2.25]", "['0.5', 2.25]", "vertex 1 must be a pair of numbers"),
        ("[0.5, 2.25]", "[0.5, 2.25, 1.0]", "vertex 1 must be a pair of numbers"),
        ("xface_face: 1", "xface_face: true", "format version True"),
        ("mated_distance: 4.25", "mated_distance: -4.25", "mated_distance must be > 0"),
    ],
    ids=[
        "impossible date",
        "mixed key types",
        "text vertex",
        "3-d vertex",
        "bool version",
        "negative mated distance",
    ],
)
def test_odd_values_are_a_face_file_error_not_a_traceback(
    tmp_path: Path, replace: str, by: str, phrase: str
) -> None:
    _refused(_file(tmp_path, X_TEXT.replace(replace, by, 1)), phrase)


def test_a_number_in_e_notation_is_a_number(tmp_path: Path) -> None:
    # PyYAML alone reads 5e-2 as text (YAML 1.1 wants 5.0e-2).
    path = _file(tmp_path, X_TEXT.replace("width: 0.05", "width: 5e-2"))
    assert xf.load_face(path).width == 0.05


# Property: valid files, mutated, load to a valid design or are refused with FaceFileError.

HOSTILE_VALUES = [
    "1" * 5000,
    "9" * 400,
    ".nan",
    "-.inf",
    "1.0e+200",
    "1e400",
    "0x" + "f" * 30,
    "[" * 300 + "]" * 300,
    "&loop [*loop]",
    "*nowhere",
    "!!python/object/apply:os.getcwd []",
    "2026-13-45",
    "true",
    "null",
    "'text'",
    "{}",
    "[]",
    "[1, [2, [3, [4]]]]",
    "{a: 1, a: 2}",
]
_NUMBER = re.compile(r"-?\d+\.\d+(?:e[-+]\d+)?")


@st.composite
def mutated_face_file(draw: st.DrawFn) -> bytes:
    text = draw(st.sampled_from(VALID_TEXTS))
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(st.sampled_from(["truncate", "flip", "value", "line"]))
        if kind == "truncate":
            text = text[: draw(st.integers(0, len(text)))]
        elif kind == "flip":
            data = bytearray(text.encode("utf-8", errors="surrogateescape"))
            if data:
                data[draw(st.integers(0, len(data) - 1))] = draw(st.integers(0, 255))
            text = data.decode("utf-8", errors="surrogateescape")
        elif kind == "value":
            numbers = list(_NUMBER.finditer(text))
            if numbers:
                match = draw(st.sampled_from(numbers))
                value = draw(st.sampled_from(HOSTILE_VALUES))
                text = text[: match.start()] + value + text[match.end() :]
        else:
            lines = text.split("\n")
            at = draw(st.integers(0, len(lines)))
            extra = draw(st.sampled_from([BILLION_LAUGHS, "width: 2.0", "mirror_symmetric: true"]))
            text = "\n".join([*lines[:at], extra, *lines[at:]])
    return text.encode("utf-8", errors="surrogateescape")


@settings(max_examples=150, suppress_health_check=[HealthCheck.too_slow])
@given(data=mutated_face_file())
def test_a_mutated_face_file_loads_a_valid_design_or_is_a_face_file_error(data: bytes) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "face.yaml"
        path.write_bytes(data)
        try:
            design = xf.load_face(path)
        except FaceFileError as exc:
            refusal = str(exc)
        else:
            refusal = None
    if refusal is not None:
        assert str(path) in refusal
        assert "\n" not in refusal
        return
    for polygon in (*design.base_layers, *design.moving_layers):
        assert abs(polygon).max() <= MAX_CUSTOM_COORDINATE
    assert 0.0 < design.width <= MAX_WIDTH
    if design.mirror_symmetric:
        assert is_mirror_symmetric(design.base_layers, design.moving_layers)
