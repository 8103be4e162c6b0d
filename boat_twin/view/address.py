"""Where the Foxglove view listens, and the SDK it needs: light (no foxglove import), for the verbs' parsers."""

from __future__ import annotations

import importlib
import ipaddress
import re
import socket
from types import ModuleType

from boat_twin.errors import InputError

DEFAULT_HOST = "127.0.0.1"
"""Loopback: the view is not reachable from other machines unless a host is given."""
DEFAULT_PORT = 8765
"""The foxglove-sdk's default WebSocket port (``foxglove.start_server``'s ``port``)."""
VIEW_MCAP = "view.mcap"
"""The view's channels recorded beside a verb's other outputs (``--out DIR``)."""
HOST_PATTERN = re.compile(r"[A-Za-z0-9.:-]+")
"""A host name, an IPv4 address or an IPv6 one (its brackets taken off)."""
INSTALL_HINT = "pip install 'boat_twin[view]' (or pip install foxglove-sdk)"


def parse_address(text: str, option: str = "--foxglove", allow_remote: bool = False,
                  remote_hint: str = "--allow-remote") -> tuple[str, int]:
    """``HOST:PORT``, ``HOST``, ``:PORT`` or empty → (host, port); the defaults where a part is left out. Port 0:
    any free port (the server says which). A host that is not loopback is refused unless ``allow_remote``: the
    view serves the boat's position to whoever connects."""
    host, sep, port_text = text.rpartition(":") if ":" in text else (text, "", "")
    host = host.strip("[]") or DEFAULT_HOST
    port = DEFAULT_PORT
    if sep:
        try:
            port = int(port_text)
        except ValueError:
            port = -1
    if not (0 <= port <= 65535 and HOST_PATTERN.fullmatch(host)):
        raise InputError(f"{option} {text!r}: expected HOST:PORT, a host name or address and a port from 0 to "
                         f"65535 (e.g. {DEFAULT_HOST}:{DEFAULT_PORT}); a trial given right after {option} is read "
                         "as its address: put the trial first")
    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)
    except (socket.gaierror, UnicodeError) as err:
        raise InputError(f"{option} {text!r}: cannot resolve host {host!r} ({err})") from None
    loopback = all(ipaddress.ip_address(str(info[4][0]).split("%")[0]).is_loopback for info in infos)
    if not loopback and not allow_remote:
        raise InputError(f"{option} {text!r}: {host} is not a loopback address; pass {remote_hint} to serve the "
                         "view beyond this machine")
    return host, port


def require_sdk(option: str = "--foxglove") -> ModuleType:
    """The ``foxglove`` module of the foxglove-sdk, or one line saying how to install it."""
    try:
        return importlib.import_module("foxglove")
    except ImportError:
        raise InputError(f"{option} needs the foxglove-sdk package: {INSTALL_HINT}") from None
