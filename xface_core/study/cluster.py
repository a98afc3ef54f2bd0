"""Connecting to a Dask cluster for a study (the ``cluster`` extra: ``dask[distributed]``).

dask is imported here only, when a scheduler address is given, so ``xface_core`` installs
and runs without it.
"""

from __future__ import annotations

from typing import Any

from xface_core.errors import XfaceError, XfaceValueError

__all__ = ["CLUSTER_HINT", "ClusterMissing", "connect"]

#: What to install for ``--scheduler``.
CLUSTER_HINT = "pip install '.[cluster]' in the xface checkout"

#: Seconds to wait for the scheduler before giving up.
CONNECT_TIMEOUT_S = 10.0

#: Address schemes of the Dask comms a scheduler listens on.
_SCHEMES = ("tcp://", "tls://", "ws://", "wss://", "inproc://", "ucx://")


class ClusterMissing(XfaceError):
    """A scheduler was given but dask.distributed is not installed."""


def connect(address: str, *, timeout_s: float = CONNECT_TIMEOUT_S) -> Any:
    """A ``dask.distributed.Client`` of the scheduler at ``address`` (``tcp://HOST:PORT``).

    Raises
    ------
    ClusterMissing
        dask.distributed is not installed.
    XfaceValueError
        The address is malformed or no scheduler answers there within ``timeout_s``.
    """
    if not address.startswith(_SCHEMES) or address.partition("://")[2] in ("", ":"):
        raise XfaceValueError(
            f"--scheduler must be an address like tcp://HOST:8786, got {address!r}"
        )
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
