"""Result types of a docking prediction: the outcome, the alignment path, margins."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from .codes import Outcome, Phase
from .geometry import FaceDesign

__all__ = ["AlignmentPath", "Counters", "Margins", "Phase", "Prediction"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


@dataclass(frozen=True)
class AlignmentPath:
    """The quasi-static path, one row per sample, in the caller's length unit.

    Samples are taken at the start, at every accepted integration step and at every event,
    so the path is exact at events and as accurate as the integrator between them.

    Attributes
    ----------
    descent : (n,) float
        How far the moving pivot has been driven along -y since the start (length).
    phi_b, phi_m : (n,) float
        Base and moving part angles (rad); the moving part starts at theta0.
    pivot_m : (n, 2) float
        Moving pivot position in the world (length); x stays x0. The base pivot is the
        origin throughout.
    phase : (n,) int
        :class:`Phase` per sample.
    contact_pairs : (n, 4) int
        Indices of the active contact features per sample, -1 padded
        (see :meth:`Prediction.contact_points`).
    """

    descent: FloatArray
    phi_b: FloatArray
    phi_m: FloatArray
    pivot_m: FloatArray
    phase: IntArray
    contact_pairs: IntArray

    def __len__(self) -> int:
        return int(self.descent.shape[0])


@dataclass(frozen=True)
class Counters:
    """Work done by one simulation."""

    steps: int
    """Accepted integration steps."""
    events: int
    """Located events (first contact, new contact, release, end of edge, end)."""
    contact_changes: int
    """Changes of the active contact set."""
    rejected_steps: int = 0
    """Integration steps rejected by the error control."""


@dataclass(frozen=True)
class Margins:
    """Distance from the query pose to the nearest pose with a different outcome.

    Each value is searched along one axis from the query (lateral: x0 with theta0 fixed;
    angle: theta0 with x0 fixed) and bisected to ``resolution``; ``inf`` when no flip exists
    within the searched range (|x0| <= 2 L, |theta0| <= pi).
    """

    lateral_minus: float
    """Length to the nearest flip towards smaller x0."""
    lateral_plus: float
    """Length to the nearest flip towards larger x0."""
    angle_minus: float
    """Radians to the nearest flip towards smaller theta0."""
    angle_plus: float
    """Radians to the nearest flip towards larger theta0."""

    @property
    def lateral(self) -> float:
        """Smallest lateral margin (length)."""
        return min(self.lateral_minus, self.lateral_plus)

    @property
    def angle(self) -> float:
        """Smallest angular margin (rad)."""
        return min(self.angle_minus, self.angle_plus)


@dataclass(frozen=True)
class Prediction:
    """Everything predicted for one initial relative pose.

    Lengths are in the design's unit (``design.width`` is D), angles in radians.
    """

    design: FaceDesign
    x0: float
    theta0: float
    y_start: float
    outcome: Outcome
    reason: str
    phi_b: float
    """Final base angle (rad)."""
    phi_m: float
    """Final moving angle (rad)."""
    pivot_m: tuple[float, float]
    """Final moving pivot position (length)."""
    counters: Counters
    path: AlignmentPath | None = None
    margins: Margins | None = None

    @property
    def seated(self) -> bool:
        """True when the dock seats."""
        return self.outcome is Outcome.SEATED

    def contact_points(self, sample: int) -> tuple[FloatArray, FloatArray]:
        """World contact points and unit normals (pointing into the moving part) of one
        path sample, as two (k, 2) arrays in the design's length unit."""
        from .contact import contact_geometry  # local: keeps result types import-light

        if self.path is None:
            raise ValueError("this prediction was made without its path")
        pairs = self.path.contact_pairs[sample]
        pairs = pairs[pairs >= 0]
        w = self.design.width
        return contact_geometry(
            self.design,
            pairs,
            self.path.phi_b[sample],
            self.path.phi_m[sample],
            self.x0 / w,
            self.path.pivot_m[sample, 1] / w,
            scale=w,
        )
