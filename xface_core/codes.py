"""The one source of every integer code the engine produces and the results store.

The compiled engine reads its constants from here (numba folds module-level IntEnum members
into constants), the typed results wrap the same values, and stored maps hold them as int8.
Renumbering a member changes stored maps and ROS messages: ``tests/core/test_codes.py``
pins the documented values.
"""

from __future__ import annotations

from enum import IntEnum

__all__ = [
    "CROSSCHECK_CONVERGE_BY",
    "REASON_TEXT",
    "EventKind",
    "Outcome",
    "Phase",
    "Reason",
    "SlipState",
]


class Outcome(IntEnum):
    """How a docking attempt ends, in priority order when several apply.

    The integer values are stable (they are stored in maps and sent over ROS) and their
    order is the priority order of the model: a lower value wins.
    """

    INVALID_INPUT = 0
    """NaN, infinity, impossible geometry, parameters out of range, interpenetrating start."""
    OUT_OF_REACH = 1
    """|x0| > L: no seated pose exists for this lateral offset (the "distance condition")."""
    NO_CONTACT = 2
    """The faces never touch along the approach."""
    SEATED = 3
    """Ended in the mated pose: equal angles, profiles flush."""
    BAD_MATE = 4
    """Jammed misaligned, or passed the point from which a seat is reachable."""
    PASSED = 5
    """The moving part slid past the base without seating."""
    UNRESOLVED = 6
    """The event or step budget ran out before any of the above was decided (a solver limit,
    never expected on the paper's grids; counted by the stress suite)."""

    @property
    def seated(self) -> bool:
        """True only for :attr:`SEATED`."""
        return self is Outcome.SEATED


class Phase(IntEnum):
    """Phase label of one path sample (docs/model.md, "Phases")."""

    APPROACH = 0
    """Pure translation along -y, angles frozen, no contact yet (or again)."""
    ALIGN = 1
    """In contact, the angles still differ: the parts rotate towards (or away from) alignment."""
    SLIDE = 2
    """In contact with equal angles: the aligned parts slide into lateral agreement."""
    END = 3
    """The final state (seated, jammed or passed)."""


class Reason(IntEnum):
    """Why a run ended: finer than :class:`Outcome` (several reasons share an outcome)."""

    SEATED = 0
    JAMMED = 1
    BELOW_SEAT = 2
    PASSED = 3
    NO_CONTACT = 4
    SPUN = 5
    SINGULAR = 6
    STEP_LIMIT = 7
    EVENT_LIMIT = 8
    OVERLAP = 9
    OUT_OF_REACH = 10
    NONFINITE = 11
    FRICTION_LOCK = 12

    @property
    def text(self) -> str:
        """The sentence a user reads (``Prediction.reason``)."""
        return REASON_TEXT[self]


#: The user-facing text of every reason (the JSON ``reason`` field and the node's messages).
REASON_TEXT: dict[Reason, str] = {
    Reason.SEATED: "seated: equal angles, profiles flush",
    Reason.JAMMED: "jammed misaligned: no further descent is possible",
    Reason.BELOW_SEAT: "descended below the seat height: a seat can no longer be reached",
    Reason.PASSED: "slid past the base: no further contact along the approach",
    Reason.NO_CONTACT: "the faces never touch along the approach",
    Reason.SPUN: "a part rotated past +-pi",
    Reason.SINGULAR: "jammed: the contact normal runs through both pivots",
    Reason.STEP_LIMIT: "step limit reached before an outcome was decided",
    Reason.EVENT_LIMIT: "event limit reached before an outcome was decided",
    Reason.OVERLAP: "the start pose interpenetrates the parts",
    Reason.OUT_OF_REACH: "|x0| exceeds the mated pivot distance L: no seated pose exists",
    Reason.NONFINITE: "non-finite input",
    Reason.FRICTION_LOCK: "jammed by friction: no slip state lets the parts descend",
}


class EventKind(IntEnum):
    """What ends a smooth segment of the path (engine-internal, listed for the unit tests)."""

    NONE = 0
    CONTACT = 1
    """A vertex reaches an edge: a new contact."""
    RELEASE = 2
    """An active contact's normal force falls to zero: it lets go."""
    OFF_EDGE = 3
    """An active contact's vertex leaves its edge's span."""
    BELOW_SEAT = 4
    """The moving pivot falls below the seat height."""
    SPUN = 5
    """A part turns past +-pi."""
    TURN = 6
    """The contact path folds back (the rate diverges): it cannot descend further."""
    SLIP = 7
    """A contact's friction state changes (slide <-> stick, or the slip reverses)."""


class SlipState(IntEnum):
    """Coulomb state of an active contact: sliding with the slip's sign, or stuck."""

    SLIDE_NEGATIVE = -1
    FREE = 0
    """No friction state chosen (frictionless, or not yet decided)."""
    SLIDE_POSITIVE = 1
    STICK = 2


#: How a converged cross-check halves the engine's step (``crosscheck(converge_by=...)``, ``xface
#: crosscheck --converge-by``): ``"grid"`` runs every cell at each halving until one changes
#: none; ``"cells"`` runs at each halving only the cells the halving before changed (each
#: cell is converged when its own last halving left it as it was). Here, not in the
#: crosscheck package, because the command line offers them without importing the engine.
CROSSCHECK_CONVERGE_BY = ("grid", "cells")
