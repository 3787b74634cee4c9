"""A Ray cluster's address, checked before Ray's minute of retries (:mod:`.distributed`)."""

from __future__ import annotations

import os
import socket

ADDRESS_VARIABLE = "RAY_ADDRESS"
"""The variable that names a cluster when no address is given."""

CONNECT_SECONDS = 5.0
"""How long a cluster address has to accept a connection before the run is refused."""


def given_address(address: object) -> str | None:
    """``address`` (the ``address`` of :class:`~.distributed.Engine`) when it is a string, None
    when it is None or empty; else a ValueError naming ``address``."""
    if address is None or isinstance(address, str):
        return address or None
    raise ValueError(
        f"address {address!r}: expected a Ray cluster address as a string (HOST:PORT, "
        "ray://HOST:PORT or auto), or None"
    )


def check_reachable(address: str) -> None:
    """A cluster address (``HOST:PORT``, ``ray://HOST:PORT``; ``auto`` is left to Ray) must
    accept a TCP connection within :data:`CONNECT_SECONDS`, else one ValueError line, at once
    (Ray itself retries for a minute and logs many lines)."""
    if address in ("auto", "local"):
        return
    host, sep, port = address.removeprefix("ray://").rpartition(":")
    if not sep or not host or not (port.isascii() and port.isdigit()):
        raise ValueError(
            f"Ray address {address!r} (--ray-address / {ADDRESS_VARIABLE}): expected HOST:PORT, "
            "ray://HOST:PORT or auto"
        )
    if not 1 <= int(port) <= 65535:
        raise ValueError(
            f"Ray address {address} (--ray-address / {ADDRESS_VARIABLE}): port {int(port)} is "
            "outside 1-65535"
        )
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=CONNECT_SECONDS).close()
    except (OSError, ValueError) as exc:
        reason = getattr(exc, "strerror", None) or str(exc) or type(exc).__name__
        raise ValueError(
            f"Ray address {address} (--ray-address / {ADDRESS_VARIABLE}): nothing answers there "
            f"({reason}); start the cluster with `ray start --head` or check the address"
        ) from None


def token_hint() -> str:
    """Joining a cluster failed and this driver sent no token: Ray >= 2.59 starts a head with
    token authentication wherever a token exists, and sends a token to an explicit address only
    with RAY_AUTH_MODE=token (so this module does not send it unasked either)."""
    if os.environ.get("RAY_AUTH_MODE", "").lower() == "token":
        return ""
    return (
        "; if the cluster uses token authentication (Ray >= 2.59 turns it on by default), set "
        "RAY_AUTH_MODE=token and the cluster's RAY_AUTH_TOKEN (or RAY_AUTH_TOKEN_PATH) here too"
    )
