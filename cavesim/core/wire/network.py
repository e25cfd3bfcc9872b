"""Zenoh sessions of every process, from typed settings: the one place a zenoh config is
built. The flags that fill the settings are parsed at the edge (`nodes/arguments.py`).

Embedded default: peer mode on loopback, multicast scouting off, gossip on (peers that
connect to the master learn of each other and connect directly, so a node can fetch a
snapshot from another node without a router). Several hosts: explicit endpoints, or a
zenoh JSON5 config file from config/zenoh/. Whichever: zenoh refuses a message larger than
the largest cavesim sends (MAX_MESSAGE_BYTES) before buffering it.
"""

from __future__ import annotations

import json
import os
import re
from dataclasses import dataclass
from pathlib import Path

import zenoh

from cavesim.core.errors import ClusterError
from cavesim.core.records import PARTICLE_BYTES
from cavesim.core.wire.payloads.state_transfer import MAX_BLOCK_BYTES, MAX_CHUNK_PARTICLES

# Zenoh lingers 10 s on closing a lost peer's TCP socket (eclipse-zenoh/zenoh#1101); with
# its default single tx thread that froze the healthy peers' traffic when a wall's link
# was cut. More runtime threads keep the barrier going. Never "": zenoh then fails to start.
RUNTIME_THREADS = "(tx: (worker_threads: 2), rx: (worker_threads: 3))"
# The largest message: a snapshot's chunk (a block reply is smaller), with room for the
# envelope, the signatures and zenoh's own framing. Zenoh's default is 1 GiB, so 45 junk
# messages of 64 MB once grew the master by 300 MB; a larger message is now dropped.
MAX_MESSAGE_BYTES = max(MAX_CHUNK_PARTICLES * PARTICLE_BYTES, MAX_BLOCK_BYTES) + 2**16


@dataclass(frozen=True)
class NetworkSettings:
    """Where this process's session listens and connects, and the zenoh config file it
    starts from (None: the embedded default). An endpoint without a protocol is refused."""

    listen: tuple[str, ...] = ()
    connect: tuple[str, ...] = ()
    config_file: Path | None = None

    def __post_init__(self) -> None:
        for endpoint in (*self.listen, *self.connect):
            if "/" not in endpoint:
                raise ValueError(f"endpoint {endpoint!r} must look like tcp/HOST:PORT")


def zenoh_config(settings: NetworkSettings) -> zenoh.Config:
    """The zenoh.Config of these settings: the file (if any), then the endpoints. A file
    zenoh cannot read is a ValueError that names it."""
    if settings.config_file is not None:
        try:
            config = zenoh.Config.from_file(str(settings.config_file))
        except Exception as e:  # zenoh raises ZError, a plain Exception subclass
            raise ValueError(f"{settings.config_file}: not a usable zenoh config: "
                             f"{zenoh_message(e)}") from e
    else:
        config = zenoh.Config()
        config.insert_json5("mode", '"peer"')
        config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("transport/link/rx/max_message_size", str(MAX_MESSAGE_BYTES))
    if settings.listen:
        config.insert_json5("listen/endpoints", json.dumps(list(settings.listen)))
    if settings.connect:
        config.insert_json5("connect/endpoints", json.dumps(list(settings.connect)))
    return config


def open_session(settings: NetworkSettings) -> zenoh.Session:
    """This process's zenoh session (use it with `with`). Zenoh reads ZENOH_RUNTIME when
    its first session opens; a user's own setting wins over RUNTIME_THREADS."""
    os.environ.setdefault("ZENOH_RUNTIME", RUNTIME_THREADS)
    config = zenoh_config(settings)
    try:
        return zenoh.open(config)
    except zenoh.ZError as e:  # e.g. an endpoint it cannot listen on
        raise ClusterError(f"cannot open a zenoh session (--listen {list(settings.listen)}, "
                           f"--connect {list(settings.connect)}): {zenoh_message(e)}") from e


def zenoh_message(error: Exception) -> str:
    """Zenoh's error text on one line, without the Rust source location it appends."""
    text = " ".join(str(error).split())
    return re.sub(r"\s*at /\S+?\.rs:\d+\.?", "", text) or type(error).__name__


def lockstep_publisher(session: zenoh.Session, key: str) -> zenoh.Publisher:
    """A publisher of messages the lock-step cannot do without (frames, controls, reports,
    the swap barrier's steps): sent at once (express) and never dropped. Zenoh's default,
    CongestionControl.DROP, drops a message its sending thread has not taken within a
    millisecond; on busy cores that lost one DRAWN in 40 frames and stalled the swap."""
    return session.declare_publisher(key, express=True,
                                     congestion_control=zenoh.CongestionControl.BLOCK)
