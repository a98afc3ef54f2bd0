"""A design as a DXF drawing for CAD (ezdxf, the ``cad`` extra).

Every outline of :func:`~xface_core.viz.facedraw.face_drawing` becomes a closed LWPOLYLINE
with the exact vertices (doubles, written at full precision), one DXF layer per part and face
layer; the pivots are POINTs on their own layers:

=====================  =================================================
DXF layer              what it holds
=====================  =================================================
``BASE_L{k}``          the base part's layer k (the base does not move: mated and start)
``MOVING_L{k}``        the moving part's layer k, mated (pivot at (0, L))
``MOVING_START_L{k}``  the moving part's layer k at the start pose (with a pose only)
``PIVOTS``             the base pivot (0, 0) and the mated moving pivot (0, L)
``PIVOTS_START``       the moving pivot at the start pose (with a pose only)
=====================  =================================================

Units: coordinates are in the drawing's length unit. ``$INSUNITS`` says metres (6) when that
unit is "m" and unitless (0) otherwise: DXF's unit codes cannot say "D" or an unnamed unit,
and a wrong code would make CAD scale the part on insertion. The unit's name, the design's
title and D (``width``) travel as the header's custom properties ``xface_unit``,
``xface_title`` and ``xface_width`` (text: ``$USERR1``..5 hold numbers only, and custom
properties show in CAD's drawing properties), and each layer's description repeats what it
holds and the unit.

Files are DXF R2013 (AC1027), which every current CAD program reads. Unlike the pictures, a
DXF carries the time it was written and fresh GUIDs in its header, as CAD programs expect.
"""

from __future__ import annotations

from pathlib import Path

from ezdxf.document import Drawing
from ezdxf.filemanagement import new as new_dxf

from .facedraw import FaceDrawing, PartsAtPose

__all__ = ["DXF_VERSION", "dxf_document", "save_face_dxf"]

#: The DXF version written: AutoCAD 2013 (read by every current CAD program).
DXF_VERSION = "R2013"
#: $INSUNITS codes: unitless and metres.
_UNITLESS, _METRES = 0, 6
#: DXF colour numbers (ACI) of the parts: blue for the base, red for the moving part, as in
#: the pictures; white/black for the pivots.
_COLORS = {"base": 5, "moving": 1, "pivot": 7}


def _add_layer(doc: Drawing, name: str, color: int, description: str) -> None:
    layer = doc.layers.add(name, color=color)
    layer.description = description


def _add_parts(
    doc: Drawing, parts: PartsAtPose, *, moving_prefix: str, with_base: bool, where: str
) -> None:
    """The outlines of one pose on their layers (``{moving_prefix}_L{k}``, ``BASE_L{k}``)."""
    msp = doc.modelspace()
    for outline in parts.outlines:
        if outline.part == "base" and not with_base:
            continue
        prefix = "BASE" if outline.part == "base" else moving_prefix
        layer = f"{prefix}_L{outline.layer}"
        if layer not in doc.layers:
            _add_layer(
                doc,
                layer,
                _COLORS[outline.part],
                f"xface {outline.part} part, face layer {outline.layer}, {where}",
            )
        points = [(float(x), float(y)) for x, y in outline.vertices]
        msp.add_lwpolyline(points, format="xy", close=True, dxfattribs={"layer": layer})


def dxf_document(drawing: FaceDrawing) -> Drawing:
    """The drawing as an ezdxf document (see the module docstring for its layers and units).

    Examples
    --------
    >>> from xface_core import x_face
    >>> from xface_core.viz.facedraw import face_drawing
    >>> doc = dxf_document(face_drawing(x_face(0.25, 1.0)))
    >>> sorted(layer.dxf.name for layer in doc.layers if layer.dxf.name.startswith("M"))
    ['MOVING_L0', 'MOVING_L1']
    >>> doc.header["$INSUNITS"], doc.header.custom_vars.get("xface_unit")
    (0, 'D')
    """
    doc = new_dxf(DXF_VERSION, units=_METRES if drawing.unit == "m" else _UNITLESS)
    doc.header["$MEASUREMENT"] = 1  # metric
    custom = doc.header.custom_vars
    custom.append("xface_title", drawing.title)
    custom.append("xface_unit", drawing.unit)
    custom.append("xface_width", repr(float(drawing.design.width)))
    unit = f"lengths in {drawing.unit}"
    _add_parts(doc, drawing.mated, moving_prefix="MOVING", with_base=True, where=f"mated; {unit}")
    _add_layer(doc, "PIVOTS", _COLORS["pivot"], f"xface pivots, mated; {unit}")
    msp = doc.modelspace()
    for pivot in (drawing.mated.base_pivot, drawing.mated.moving_pivot):
        msp.add_point(pivot, dxfattribs={"layer": "PIVOTS"})
    if drawing.start is not None:
        _add_parts(
            doc,
            drawing.start,
            moving_prefix="MOVING_START",
            with_base=False,
            where=f"at the start pose; {unit}",
        )
        _add_layer(
            doc, "PIVOTS_START", _COLORS["pivot"], f"xface moving pivot at the start; {unit}"
        )
        msp.add_point(drawing.start.moving_pivot, dxfattribs={"layer": "PIVOTS_START"})
    return doc


def save_face_dxf(drawing: FaceDrawing, path: str | Path) -> Path:
    """Write :func:`dxf_document` to ``path`` (ASCII DXF) and return the path.

    Raises
    ------
    OSError
        The file cannot be written.
    """
    out = Path(path)
    dxf_document(drawing).saveas(out)
    return out
