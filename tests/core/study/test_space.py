"""Design spaces with face files: a file is one fixed design per friction and damping ratio,
named by its name and told apart by the digest of its geometry."""

from __future__ import annotations

from dataclasses import replace

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from xface_core.errors import XfaceValueError
from xface_core.geometry import x_face
from xface_core.study.space import DesignPoint, DesignSpace, FileFace, face_digest

TRAP = FileFace("trap.yaml", replace(x_face(0.25, 2.0, width=0.05), name="trap"))
OTHER_TRAP = FileFace("other/trap.yaml", replace(x_face(0.5, 2.0), name="trap"))


def test_a_face_file_is_one_design_per_friction_and_damping_ratio() -> None:
    space = DesignSpace(
        faces=(), h_over_d=(), r_p=(), friction=(0.0, 0.3), damping_ratio=(1.0,),
        face_files=(TRAP,),
    )  # fmt: skip
    points = space.points()
    assert len(space) == len(points) == 2
    assert all(p.h_over_d is None and p.r_p is None and p.face == "trap" for p in points)
    assert space.design(points[0]) is TRAP.design


def test_face_files_join_the_built_in_faces_without_their_h_over_d_and_r_p() -> None:
    space = DesignSpace(faces=("X",), h_over_d=(0.25, 0.5), r_p=(1.0,), face_files=(TRAP,))
    points = space.points()
    assert len(points) == len(space) == 3
    assert points[-1] == DesignPoint("trap", None, None, 0.0, 1.0, TRAP.digest)


def test_two_files_of_one_name_stay_apart_by_their_digest() -> None:
    space = DesignSpace(faces=(), h_over_d=(), r_p=(), face_files=(TRAP, OTHER_TRAP))
    first, second = space.points()
    assert first.face == second.face == "trap"
    assert first.face_digest != second.face_digest
    assert space.design(second) is OTHER_TRAP.design


def test_the_same_file_twice_is_refused() -> None:
    again = FileFace("copy.yaml", TRAP.design)
    with pytest.raises(XfaceValueError, match="same design under the same name 'trap'"):
        DesignSpace(faces=(), h_over_d=(), r_p=(), face_files=(TRAP, again)).points()


@settings(max_examples=30, deadline=None)
@given(
    width=st.floats(1e-3, 1e3, allow_nan=False),
    name=st.text(min_size=1, max_size=20),
    h_over_d=st.floats(0.05, 5.0),
)
def test_a_digest_depends_on_the_geometry_alone(width: float, name: str, h_over_d: float) -> None:
    # Width and name change neither the study's result (it runs in D) nor the digest; the
    # geometry (here H/D, or the face) does.
    design = x_face(h_over_d, 2.0)
    assert face_digest(replace(design.with_width(width), name=name)) == face_digest(design)
    other = x_face(h_over_d * 1.5, 2.0)
    assert face_digest(other) != face_digest(design)
