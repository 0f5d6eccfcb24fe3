"""Which Host a server bound to an address answers to: the defence against DNS rebinding that every server a
browser can reach shares (the viewer's HTTP server, the Foxglove WebSocket server)."""

from __future__ import annotations

import ipaddress
import re
import socket

_DIGITS = re.compile(r"[0-9]+")
#: browser pages that may open the Foxglove WebSocket by default: the Foxglove app, and pages of the robot's own
#: viewer at its default address (a client that sends no Origin is not a browser, and always may)
FOXGLOVE_ALLOWED_ORIGINS = ("https://app.foxglove.dev", "http://127.0.0.1:8765", "http://localhost:8765")
#: the most origins an allowed list may hold, and the longest origin
MAX_ORIGINS, MAX_ORIGIN_CHARS = 64, 256
_ORIGIN = re.compile(r"[a-z][a-z0-9+.-]*://[^/?#\s]+/?", re.IGNORECASE)


def parse_origins(text: str, where: str) -> tuple[str, ...]:
    """The origins of a space-separated list, each scheme://host[:port] as a browser sends it (not "null", which
    any sandboxed page sends); ValueError naming ``where`` and the first one that is not."""
    origins = tuple(text.split())
    if len(origins) > MAX_ORIGINS:
        raise ValueError(f"{where}: at most {MAX_ORIGINS} origins, got {len(origins)}")
    for origin in origins:
        if len(origin) > MAX_ORIGIN_CHARS or not _ORIGIN.fullmatch(origin):
            raise ValueError(f"{where}: {origin[:MAX_ORIGIN_CHARS]!r} is not an origin (scheme://host[:port], at "
                             f"most {MAX_ORIGIN_CHARS} characters)")
    return tuple(o.rstrip("/") for o in origins)


def _ip(name: str):
    try:
        return ipaddress.ip_address(name)
    except ValueError:
        return None


def split_authority(authority: str) -> tuple[str, int | None]:
    """A Host header as (lower-case host name, port); the port is 80 when absent, None when malformed."""
    authority = authority.strip().lower()
    if authority.startswith("["):
        host, _, rest = authority[1:].partition("]")
        port = rest[1:] if rest.startswith(":") else ("80" if not rest else "")
    else:
        host, colon, port = authority.partition(":")
        port = port if colon else "80"
    return host, int(port) if _DIGITS.fullmatch(port) else None


def is_own_host(authority: str, bound: str, port: int, machine_names: frozenset[str]) -> bool:
    """Whether a Host header addresses the server bound to bound:port.

    A loopback server answers to any loopback address and "localhost"; one on every interface
    (0.0.0.0) to any IP address and this machine's names; others to their address and the
    machine's names. A domain name from elsewhere is what a DNS-rebinding page sends.
    """
    name, asked_port = split_authority(authority)
    if asked_port != port:
        return False
    address, bound_ip = _ip(name), ipaddress.ip_address(bound)
    if bound_ip.is_loopback:
        return name == "localhost" or (address is not None and address.is_loopback)
    if bound_ip.is_unspecified:
        return address is not None or name == "localhost" or name in machine_names
    return address == bound_ip or name in machine_names


def machine_names(bound: str) -> frozenset[str]:
    """The names a server bound to ``bound`` also answers to: none on loopback, else this machine's own."""
    if ipaddress.ip_address(bound).is_loopback:
        return frozenset()
    return frozenset(n.lower() for n in (socket.gethostname(), socket.getfqdn()))
