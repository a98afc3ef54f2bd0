"""Predict a dock: :func:`predict`, one pose with its path and optionally its margins.

Lengths are in the design's unit (``design.width`` is the face width D), angles in radians.
The engine works in units of D, so maps and outcomes do not depend on the unit. The batch
API and the settings live in :mod:`.runner` and :mod:`.physics` and are re-exported here.
"""

from __future__ import annotations

from dataclasses import replace

from .atlas.build import AcceptanceAtlas
from .atlas.lookup import margins_from_atlas
from .atlas.margins import outcome_margins
from .codes import REASON_TEXT
from .geometry import FaceDesign
from .physics import DEFAULT_SETTINGS, MAX_FRICTION, Physics, SolverSettings
from .result import Prediction
from .runner import (
    MAX_OFFSET,
    BatchResult,
    predict_batch,
    simulate_pose,
    start_height,
    start_heights,
)

__all__ = [
    "DEFAULT_SETTINGS",
    "MAX_FRICTION",
    "MAX_OFFSET",
    "REASONS",
    "BatchResult",
    "SolverSettings",
    "predict",
    "predict_batch",
    "start_height",
    "start_heights",
]

#: Reason texts keyed by the integer reason code (see :class:`~xface_core.codes.Reason`).
REASONS: dict[int, str] = {int(reason): text for reason, text in REASON_TEXT.items()}


def predict(
    design: FaceDesign,
    x0: float,
    theta0: float,
    *,
    y_start: float | None = None,
    physics: Physics | None = None,
    damping_ratio: float | None = None,
    friction: float | None = None,
    path: bool = True,
    margins: bool = False,
    settings: SolverSettings | None = None,
    atlas: AcceptanceAtlas | None = None,
    margin_threads: int | None = None,
) -> Prediction:
    """Predict whether the faces seat from one initial relative pose.

    Parameters
    ----------
    design : FaceDesign
        The connector (``design.width`` is D in the caller's length unit).
    x0 : float
        Lateral offset of the moving pivot (length).
    theta0 : float
        Initial angle of the moving part relative to the mated orientation (rad).
    y_start : float, optional
        Initial height of the moving pivot above the base pivot (length). Default: just
        clear of the base for this angle (the approach is exact, so the start does not
        change the outcome as long as the parts do not overlap).
    physics : Physics, optional
        Damping ratio, friction and solver settings as one validated value (default:
        ``Physics()``, the paper's frictionless model with equal damping). The three loose
        keywords below are the older spelling of the same; give one or the other.
    damping_ratio : float
        Rotational damping of the base over that of the moving part, c_B / c_M; ``inf``
        holds the base fixed.
    friction : float
        Coulomb friction coefficient at every contact (0, the paper's assumption, by
        default; the paper names friction as future work).
    path : bool
        Keep the alignment path (costs memory, not much time).
    margins : bool
        Also search the distance to the nearest pose with a different outcome.
    settings : SolverSettings
        Numerical settings of the integrator.
    atlas : AcceptanceAtlas, optional
        With ``margins``: read the margins from this atlas (built for this design and
        physics) and confirm them exactly (:func:`~xface_core.atlas.lookup.margins_from_atlas`:
        the same values as the exact search, with a fraction of its simulations). The pose
        itself is always simulated.
    margin_threads : int, optional
        With ``margins`` and ``atlas``: threads that share each batch of confirmation
        simulations (default: one per core; see
        :func:`~xface_core.atlas.lookup.margins_from_atlas`).

    Returns
    -------
    Prediction

    Examples
    --------
    >>> from xface_core import x_face
    >>> p = predict(x_face(0.25, 2.0), 0.3, 0.2)
    >>> p.outcome.name, p.seated
    ('SEATED', True)
    >>> predict(x_face(0.25, 0.0), 0.9, 0.0).outcome.name
    'OUT_OF_REACH'
    """
    phys = Physics.resolve(
        physics, damping_ratio=damping_ratio, friction=friction, settings=settings
    )
    prediction = simulate_pose(design, x0, theta0, phys, y_start=y_start, path=path)
    if margins and atlas is not None:
        found = margins_from_atlas(
            atlas.bound_to(design, phys),
            x0,
            theta0,
            prediction.outcome,
            y_start=y_start,
            threads=margin_threads,
        )
        prediction = replace(prediction, margins=found)
    elif margins:
        found = outcome_margins(
            design, x0, theta0, prediction.outcome, physics=phys, y_start=y_start
        )
        prediction = replace(prediction, margins=found)
    return prediction
