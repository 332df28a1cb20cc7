"""Drake's Meshcat server: start it on a host/port, and the checks around that.

Nothing starts at import: a server exists only once `start_meshcat` is called (by the
`meshcat` effect or `testbed view`). Meshcat has no authentication, so anything but a
loopback host gets a warning (`exposure_warning`).
"""

from __future__ import annotations

import ipaddress
import socket
from pathlib import Path

from testbed.errors import TestbedError

DEFAULT_PORT = 7000


class MeshcatPortError(TestbedError, RuntimeError):
    """The Meshcat server could not listen on the requested host/port (usually: in use)."""

    def __init__(self, host: str, port: int | None, detail: str):
        self.host, self.port = host, port
        super().__init__(
            f"cannot start the Meshcat viewer on {host}:{port}: {detail}; the port is probably in use "
            f"(another viewer?). Choose another with --port P (e.g. --port {(port or DEFAULT_PORT) + 1}), "
            f"or --port 0 to let the system pick a free one"
        )

def is_loopback_host(host: str) -> bool:
    """True if `host` names only this machine's loopback interface ("localhost", 127.x, ::1)."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def exposure_warning(host: str) -> str | None:
    """The warning to print for a non-loopback host, or None for loopback ones."""
    if is_loopback_host(host):
        return None
    where = "every network interface" if host in ("*", "0.0.0.0", "::") else f"the address {host}"
    return (f"WARNING: the viewer listens on {where}. Meshcat has no authentication: anyone who "
            f"can reach this machine on that port can watch the scene and send it commands. "
            f"Use the default --host localhost unless you trust the network.")


def start_meshcat(host: str = "localhost", port: int | None = DEFAULT_PORT, *, quiet: bool = False):
    """Starts a Meshcat server. port None or 0 = any free port (0: the system's choice).
    quiet: Drake does not log its "Meshcat listening for connections at URL" line (for a
    server that only records a replay file: its URL is gone when the command exits).

    Raises MeshcatPortError (a TestbedError) naming the port when it cannot listen.
    """
    import logging

    from pydrake.geometry import Meshcat, MeshcatParams

    params = MeshcatParams(host=host, port=port if port else 0, show_stats_plot=False)
    drake_log = logging.getLogger("drake")  # pydrake forwards Drake's log here
    level = drake_log.level
    if quiet:
        drake_log.setLevel(max(level, logging.WARNING))
    try:
        return Meshcat(params)
    except RuntimeError as e:
        raise MeshcatPortError(host, port, str(e).strip().splitlines()[0]) from None
    finally:
        drake_log.setLevel(level)


def listening_addresses(port: int) -> list[str]:
    """Local addresses ('127.0.0.1', '::1', '0.0.0.0', ...) with a TCP socket in LISTEN
    state on `port`, read from /proc/net/tcp and /proc/net/tcp6 (Linux only)."""
    out = []
    for name, family in (("/proc/net/tcp", socket.AF_INET), ("/proc/net/tcp6", socket.AF_INET6)):
        try:
            lines = Path(name).read_text().splitlines()[1:]
        except OSError:
            continue
        for line in lines:
            fields = line.split()
            local, state = fields[1], fields[3]
            address_hex, port_hex = local.split(":")
            if state != "0A" or int(port_hex, 16) != port:  # 0A = TCP_LISTEN
                continue
            raw = bytes.fromhex(address_hex)
            # /proc prints each 32-bit word in host (little-endian) byte order.
            raw = b"".join(raw[i:i + 4][::-1] for i in range(0, len(raw), 4))
            out.append(socket.inet_ntop(family, raw))
    return out
