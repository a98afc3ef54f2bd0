"""Outcome codes: every simulated dock ends in exactly one of them (defined in :mod:`.codes`)."""

from __future__ import annotations

from .codes import Outcome

__all__ = ["Outcome"]
