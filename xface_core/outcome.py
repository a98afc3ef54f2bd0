"""Outcome codes: every simulated dock ends in exactly one of them."""

from __future__ import annotations

from enum import IntEnum

__all__ = ["Outcome"]


class Outcome(IntEnum):
    """How a docking attempt ends, in priority order when several apply.

    The integer values are stable (they are stored in maps and sent over ROS) and their
    order is the priority order of MODEL.md: a lower value wins.
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
