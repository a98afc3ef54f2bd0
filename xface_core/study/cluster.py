"""Connecting to a Dask cluster for a study (the ``cluster`` extra: ``dask[distributed]``).

dask is imported here only, when a scheduler address is given, so ``xface_core`` installs
and runs without it.
"""

from __future__ import annotations

import ipaddress
import re
from typing import Any
from urllib.parse import urlsplit

from xface_core.errors import XfaceError, XfaceValueError

__all__ = ["CLUSTER_HINT", "ClusterMissing", "check_address", "connect"]

#: What to install for ``--scheduler``.
CLUSTER_HINT = "pip install '.[cluster]' in the xface checkout"

#: Seconds to wait for the scheduler before giving up.
CONNECT_TIMEOUT_S = 10.0

#: Address schemes of the Dask comms a scheduler listens on.
_SCHEMES = ("tcp://", "tls://", "ws://", "wss://", "inproc://", "ucx://")

#: A host name (RFC 1123 labels, dot-separated; underscores tolerated).
_HOST_NAME = re.compile(
    r"[A-Za-z0-9_]([A-Za-z0-9_-]{0,62})(\.[A-Za-z0-9_]([A-Za-z0-9_-]{0,62}))*\.?"
)


class ClusterMissing(XfaceError):
    """A scheduler was given but dask.distributed is not installed."""


def _address_problem(address: str) -> str | None:
    """What is wrong with the form of a scheduler address, or None."""
    if not address.startswith(_SCHEMES):
        return f"no protocol; one of {', '.join(_SCHEMES)}"
    rest = address.partition("://")[2]
    if rest in ("", ":"):
        return "no host"
    if address.startswith("inproc://"):
        return None  # this process's own scheduler: the form is Dask's business
    try:
        parts = urlsplit(address)
        port = parts.port
    except ValueError as exc:  # a port that is no number or out of range, a broken [IPv6]
        return str(exc)
    host = parts.hostname or ""
    if parts.username is not None or parts.path or parts.query or parts.fragment:
        return "only HOST:PORT may follow the protocol"
    if not host:
        return "no host"
    if port is None or not 1 <= port <= 65535:
        return "no port in 1..65535"
    try:
        ipaddress.ip_address(host)
    except ValueError:
        if not _HOST_NAME.fullmatch(host):
            return f"{host!r} is not a host name or IP address"
    return None


def check_address(address: str) -> None:
    """Raise :class:`XfaceValueError` (one line) unless ``address`` has the form
    ``PROTOCOL://HOST:PORT``; checked before connecting, so a typo is reported at once
    (Dask reports some only after its connect timeout, with a traceback from its client)."""
    problem = _address_problem(address)
    if problem is not None:
        raise XfaceValueError(
            f"--scheduler must be an address like tcp://HOST:8786, got {address!r} ({problem})"
        )


def connect(address: str, *, timeout_s: float = CONNECT_TIMEOUT_S) -> Any:
    """A ``dask.distributed.Client`` of the scheduler at ``address`` (``tcp://HOST:PORT``).

    Raises
    ------
    ClusterMissing
        dask.distributed is not installed.
    XfaceValueError
        The address is malformed (:func:`check_address`) or no scheduler answers there
        within ``timeout_s``.
    """
    check_address(address)
    try:
        from distributed import Client
    except ImportError:
        raise ClusterMissing(f"--scheduler needs the cluster extra: {CLUSTER_HINT}") from None
    try:
        return Client(address, timeout=timeout_s, set_as_default=False)  # type: ignore[no-untyped-call]
    except (OSError, TimeoutError, ValueError) as exc:
        raise XfaceValueError(
            f"cannot reach the Dask scheduler at {address} within {timeout_s:g} s ({exc})"
        ) from None
