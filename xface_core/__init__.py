"""xface_core: will a passive planar dock seat, and along which path?

A quasi-static simulator of two planar connector faces (the X-Face of Eckenstein & Yim and
the V- and S-Faces it is compared with), each free to rotate about its own pivot, one pivot
driven straight at the other. Lengths are in the design's unit (its ``width`` is the face
width D), angles in radians.

Examples
--------
>>> import xface_core as xf
>>> design = xf.x_face(h_over_d=0.25, r_p=2.0)
>>> p = xf.predict(design, x0=0.3, theta0=0.2)
>>> p.outcome, p.seated
(<Outcome.SEATED: 3>, True)
>>> xf.acceptance_map(design).M
303
"""

from __future__ import annotations

from .atlas.approach import ApproachSuggestion, suggest_approach
from .atlas.build import AcceptanceAtlas, build_atlas
from .atlas.lookup import margins_from_atlas
from .atlas.margins import outcome_margins
from .atlas.probability import seat_probability
from .codes import Outcome, Reason
from .errors import FaceFileError, GeometryError, InputError, XfaceError, XfaceValueError
from .facefile import load_face, save_face
from .geometry import FaceDesign, custom_face, make_face, s_face, v_face, x_face
from .maps.acceptance import AcceptanceMap, MTable, acceptance_map, m_table
from .maps.grids import PAPER_H_OVER_D, PAPER_R_P, theta_grid, x0_grid
from .maps.regions import largest_centred_rectangle, largest_rectangle
from .physics import DEFAULT_SETTINGS, Physics, SolverSettings
from .predict import predict
from .result import AlignmentPath, Counters, Margins, Phase, Prediction
from .runner import BatchResult, predict_batch

__all__ = [
    "DEFAULT_SETTINGS",
    "PAPER_H_OVER_D",
    "PAPER_R_P",
    "AcceptanceAtlas",
    "AcceptanceMap",
    "AlignmentPath",
    "ApproachSuggestion",
    "BatchResult",
    "Counters",
    "FaceDesign",
    "FaceFileError",
    "GeometryError",
    "InputError",
    "MTable",
    "Margins",
    "Outcome",
    "Phase",
    "Physics",
    "Prediction",
    "Reason",
    "SolverSettings",
    "XfaceError",
    "XfaceValueError",
    "acceptance_map",
    "build_atlas",
    "custom_face",
    "largest_centred_rectangle",
    "largest_rectangle",
    "load_face",
    "m_table",
    "make_face",
    "margins_from_atlas",
    "outcome_margins",
    "predict",
    "predict_batch",
    "s_face",
    "save_face",
    "seat_probability",
    "suggest_approach",
    "theta_grid",
    "v_face",
    "x0_grid",
    "x_face",
]
