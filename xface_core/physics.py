"""The physics of a dock besides its geometry: damping ratio, friction and solver settings.

:class:`Physics` is one validated value passed to every entry point (``predict``,
``predict_batch``, ``outcome_margins``, ``acceptance_map``, ``m_table``), the CLI and the
ROS node's parameters, instead of three loose arguments threaded through each of them.
Constructing one checks it: an invalid value raises :class:`~xface_core.errors.XfaceValueError`
naming the field, so callers (the node's parameter callback, the CLI) validate by building one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace
from typing import cast

from .errors import XfaceValueError, is_integer_in, real_number

__all__ = [
    "DEFAULT_PHYSICS",
    "DEFAULT_SETTINGS",
    "MAX_DAMPING_RATIO",
    "MAX_FRICTION",
    "MIN_DAMPING_RATIO",
    "Physics",
    "SolverSettings",
]

#: Largest accepted Coulomb friction coefficient (steel on steel is about 0.6).
MAX_FRICTION = 10.0

#: Supported damping ratios c_B / c_M besides ``inf`` (a base that does not turn). Beyond
#: four decades either way the two parts' rates differ by more than the integrator can carry
#: in double precision: at 1e6 and 1e-6, 0.5 % of random poses ended UNRESOLVED, at 1e9 and
#: 1e-9 over 4 %, and 1e-300 gave NaN angles; from 1e-4 to 1e4 none did. Use ``inf`` for a
#: base held still.
MIN_DAMPING_RATIO = 1e-4
MAX_DAMPING_RATIO = 1e4


#: Bounds of the solver's tolerances (dimensionless or D): outside them the integrator is
#: either meaningless (>= 1) or below double precision's resolution of the state.
_TOLERANCE_RANGE = (1e-16, 1e-1)


@dataclass(frozen=True)
class SolverSettings:
    """Numerical settings of the alignment integrator (lengths in D, angles in rad).

    The defaults give maps identical to those at tolerances 1e-12 (see ``xface bench``).
    Invalid values raise :class:`~xface_core.errors.XfaceValueError` on construction.
    """

    rtol: float = 1e-8
    """Relative error per step of the angles."""
    atol: float = 1e-10
    """Absolute error per step of the angles (rad)."""
    event_tol: float = 1e-12
    """Width (in descent, D) to which events are located."""
    touch_tol: float = 1e-9
    """Gap (D) below which a vertex-edge pair counts as touching."""
    seat_tol: float = 1e-4
    """Tolerance of the seated-pose test: |phi_B - phi_M| (rad) and the pivot's distance from
    the mated position (in D, per D of L). Where the path reaches the seat through a fold of
    the contact path (a pinned corner turning into flush flanks, as in the V-Face) the
    angles there are only determined to about sqrt(event_tol) times a geometric factor
    (1e-5 seen), so the test must be looser than that; 1e-4 D is far below any machining
    tolerance."""
    max_step: float = 0.25
    """Largest descent step (D); also bounds how far a vertex can move unchecked. The
    engine keeps a step within half the design's shortest edge as well, but never below
    0.05 D (or this bound, if smaller)."""
    first_step: float = 1e-3
    """Initial descent step (D)."""
    max_steps: int = 20000
    """Accepted integration steps after which a run ends UNRESOLVED."""
    max_events: int = 400
    """Events after which a run ends UNRESOLVED."""
    jam_speed: float = 1e6
    """Rotation rate (rad per D of descent) treated as a jam (normal through both pivots)."""

    def __post_init__(self) -> None:
        lo, hi = _TOLERANCE_RANGE
        for name in ("rtol", "atol", "event_tol", "touch_tol", "seat_tol"):
            value = real_number(getattr(self, name))
            if value is None or not lo <= value <= hi:
                raise XfaceValueError(
                    f"settings.{name} must be in [{lo:g}, {hi:g}], got {getattr(self, name)!r}"
                )
        for name in ("max_step", "first_step", "jam_speed"):
            value = real_number(getattr(self, name))
            if value is None or not 0.0 < value < math.inf:
                raise XfaceValueError(
                    f"settings.{name} must be finite and > 0, got {getattr(self, name)!r}"
                )
        for name in ("max_steps", "max_events"):
            value = getattr(self, name)
            if not is_integer_in(value, 1):
                raise XfaceValueError(f"settings.{name} must be an integer >= 1, got {value!r}")

    def tightened(self, factor: float) -> SolverSettings:
        """All tolerances multiplied by ``factor`` (< 1 tightens)."""
        return replace(
            self,
            rtol=self.rtol * factor,
            atol=self.atol * factor,
            event_tol=max(self.event_tol * factor, 1e-15),
        )


DEFAULT_SETTINGS = SolverSettings()

#: The paper's model: equal rotational damping of both parts, no friction.
DEFAULT_DAMPING_RATIO = 1.0
DEFAULT_FRICTION = 0.0


@dataclass(frozen=True)
class Physics:
    """Everything about a dock that is not geometry or pose.

    Invalid values raise :class:`~xface_core.errors.XfaceValueError` on construction, so
    ``Physics(**values)`` is the public validation of a set of physical parameters.

    Examples
    --------
    >>> Physics(friction=0.2).friction
    0.2
    >>> Physics(damping_ratio=0.0)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    xface_core.errors.XfaceValueError: damping_ratio must be in [0.0001, 10000] or inf ...
    """

    damping_ratio: float = DEFAULT_DAMPING_RATIO
    """Rotational damping of the base over that of the moving part, c_B / c_M, in
    [MIN_DAMPING_RATIO, MAX_DAMPING_RATIO]; ``inf`` holds the base fixed."""
    friction: float = DEFAULT_FRICTION
    """Coulomb friction coefficient at every contact, in [0, MAX_FRICTION] (0: the paper's
    frictionless model)."""
    settings: SolverSettings = field(default=DEFAULT_SETTINGS)
    """Numerical settings of the integrator."""

    def __post_init__(self) -> None:
        d, mu = (
            real_number(cast(object, self.damping_ratio)),
            real_number(cast(object, self.friction)),
        )
        if d is None or not (MIN_DAMPING_RATIO <= d <= MAX_DAMPING_RATIO or d == math.inf):
            raise XfaceValueError(
                f"damping_ratio must be in [{MIN_DAMPING_RATIO:g}, {MAX_DAMPING_RATIO:g}] or inf "
                f"(a base that does not turn), got {self.damping_ratio!r}"
            )
        if mu is None or not 0.0 <= mu <= MAX_FRICTION:
            raise XfaceValueError(
                f"friction must be in [0, {MAX_FRICTION:g}], got {self.friction!r}"
            )
        if not isinstance(self.settings, SolverSettings):
            raise XfaceValueError(f"settings must be a SolverSettings, got {self.settings!r}")
        # Normalise ints (a YAML "1" or a CLI "0") so equal physics compare and hash equal.
        object.__setattr__(self, "damping_ratio", d)
        object.__setattr__(self, "friction", mu)

    @property
    def base_fixed(self) -> bool:
        """True when the base cannot turn (infinite damping ratio)."""
        return math.isinf(self.damping_ratio)

    @classmethod
    def resolve(
        cls,
        physics: Physics | None = None,
        *,
        damping_ratio: float | None = None,
        friction: float | None = None,
        settings: SolverSettings | None = None,
    ) -> Physics:
        """The physics an entry point runs with: ``physics`` itself, or one built from the
        loose keyword arguments (the older spelling, still accepted); not both."""
        if physics is None and damping_ratio is None and friction is None and settings is None:
            return DEFAULT_PHYSICS  # the common call, without building and checking it again
        loose = {"damping_ratio": damping_ratio, "friction": friction, "settings": settings}
        given = sorted(k for k, v in loose.items() if v is not None)
        if physics is None:
            return cls(
                damping_ratio=DEFAULT_DAMPING_RATIO if damping_ratio is None else damping_ratio,
                friction=DEFAULT_FRICTION if friction is None else friction,
                settings=DEFAULT_SETTINGS if settings is None else settings,
            )
        if not isinstance(physics, Physics):
            raise XfaceValueError(f"physics must be a Physics, got {physics!r}")
        if given:
            names = ", ".join(given)
            raise XfaceValueError(f"give either physics or {names}, not both")
        return physics

    def as_dict(self) -> dict[str, float]:
        """damping_ratio and friction (the settings stay out: they are not physics)."""
        return {f.name: getattr(self, f.name) for f in fields(self) if f.name != "settings"}


DEFAULT_PHYSICS = Physics()
