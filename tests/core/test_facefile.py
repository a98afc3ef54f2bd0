"""Face files (xface_core.facefile): round trips, the format's checks, clear errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

import xface_core as xf
from xface_core import FaceFileError, GeometryError

SQUARE = [[-0.5, -1.0], [0.5, -1.0], [0.5, 0.25], [-0.5, 0.25]]


def _write(tmp_path: Path, doc: object) -> Path:
    path = tmp_path / "face.yaml"
    path.write_text(yaml.safe_dump(doc), encoding="utf-8")
    return path


def _doc(**changes: object) -> dict[str, object]:
    doc: dict[str, object] = {
        "xface_face": 1,
        "name": "block",
        "width": 0.05,
        "mated_distance": 2.5,
        "layers": [{"base": SQUARE, "moving": SQUARE}],
    }
    doc.update(changes)
    return doc


@pytest.mark.parametrize(
    "design",
    [xf.x_face(0.25, 2.0, width=0.05), xf.v_face(0.5, 1.0), xf.s_face(0.32988, 2.0)],
    ids=["X", "V", "S"],
)
def test_the_built_in_faces_round_trip_to_identical_maps(
    design: xf.FaceDesign, tmp_path: Path
) -> None:
    loaded = xf.load_face(xf.save_face(design, tmp_path / "face.yaml"))
    assert loaded.width == design.width
    assert loaded.mated_distance == design.mated_distance
    assert loaded.mirror_symmetric == design.mirror_symmetric
    before = xf.acceptance_map(design)
    after = xf.acceptance_map(loaded)
    assert np.array_equal(before.outcomes, after.outcomes)


def test_a_saved_file_names_the_design(tmp_path: Path) -> None:
    path = xf.save_face(xf.v_face(0.5, 1.0), tmp_path / "v.yaml")
    doc = yaml.safe_load(path.read_text())
    assert doc["name"] == "V-Face H/D 0.5 r_p 1"
    assert doc["xface_face"] == 1


def test_a_hand_written_file_loads_like_custom_face(tmp_path: Path) -> None:
    loaded = xf.load_face(_write(tmp_path, _doc()))
    direct = xf.custom_face([SQUARE], [SQUARE], mated_distance=2.5, width=0.05)
    assert np.array_equal(loaded.base_layers[0], direct.base_layers[0])
    assert loaded.width == 0.05


@pytest.mark.parametrize(
    ("doc", "message"),
    [
        (_doc(xface_face=2), "format version 2"),
        ({"name": "x"}, "misses xface_face, mated_distance, layers"),
        (_doc(colour="red"), "unknown keys colour"),
        (_doc(mated_distance="far"), "mated_distance must be a number"),
        (_doc(width=float("inf")), "must be finite"),
        (_doc(layers=[]), "non-empty list"),
        (_doc(layers=[{"base": SQUARE}]), "exactly the keys base and moving"),
        (_doc(mirror_symmetric="yes please"), "true or false"),
        (["not", "a", "mapping"], "YAML mapping"),
    ],
)
def test_a_file_off_the_format_is_a_face_file_error(
    tmp_path: Path, doc: object, message: str
) -> None:
    with pytest.raises(FaceFileError, match=message):
        xf.load_face(_write(tmp_path, doc))


def test_impossible_geometry_in_a_file_is_a_geometry_error_naming_the_file(tmp_path: Path) -> None:
    path = _write(tmp_path, _doc(mated_distance=0.2))
    with pytest.raises(GeometryError, match=r"face\.yaml.*the mated parts overlap"):
        xf.load_face(path)


def test_ragged_vertices_in_a_file_are_a_geometry_error(tmp_path: Path) -> None:
    path = _write(tmp_path, _doc(layers=[{"base": [[0, 0], [1]], "moving": SQUARE}]))
    with pytest.raises(GeometryError, match="vertex 1 must be a pair of numbers"):
        xf.load_face(path)


def test_a_missing_file_is_a_face_file_error(tmp_path: Path) -> None:
    with pytest.raises(FaceFileError, match="cannot read the face file"):
        xf.load_face(tmp_path / "nowhere.yaml")


def test_text_that_is_not_yaml_is_a_face_file_error(tmp_path: Path) -> None:
    path = tmp_path / "face.yaml"
    path.write_text("layers: [unclosed", encoding="utf-8")
    with pytest.raises(FaceFileError, match="not valid YAML"):
        xf.load_face(path)


def test_an_unwritable_path_is_a_face_file_error(tmp_path: Path) -> None:
    with pytest.raises(FaceFileError, match="cannot write the face file"):
        xf.save_face(xf.x_face(0.25, 2.0), tmp_path / "no" / "such" / "dir" / "face.yaml")
