"""Zenoh session settings shared by every process: one place for --listen/--connect/--config.

Embedded default: peer mode on loopback, multicast scouting off, gossip on (peers that
connect to the master learn of each other and connect directly, so a node can fetch a
snapshot from another node without a router). Several hosts: explicit endpoints, or a
zenoh JSON5 config file from config/zenoh/.
"""

from __future__ import annotations

import argparse
import json
import os
import re
from dataclasses import dataclass
from pathlib import Path

import zenoh

from cavesim.core.errors import ClusterError
from cavesim.core.limits import DEFAULT_MASTER_PORT
from cavesim.core.wire.credentials import Credentials, read_credentials
from cavesim.core.wire.key_expressions import check_name

# Zenoh lingers 10 s on closing a lost peer's TCP socket (eclipse-zenoh/zenoh#1101); with
# its default single tx thread that froze the healthy peers' traffic when a wall's link
# was cut. More runtime threads keep the barrier going. Never "": zenoh then fails to start.
RUNTIME_THREADS = "(tx: (worker_threads: 2), rx: (worker_threads: 3))"


@dataclass(frozen=True)
class NetworkConfig:
    listen: tuple[str, ...] = ()
    connect: tuple[str, ...] = ()
    config_file: Path | None = None

    def zenoh_config(self) -> zenoh.Config:
        """The zenoh.Config of this process: the file (if any), then the endpoints."""
        if self.config_file is not None:
            try:
                config = zenoh.Config.from_file(str(self.config_file))
            except Exception as e:  # zenoh raises ZError, a plain Exception subclass
                raise ValueError(f"--config {self.config_file}: not a usable zenoh config: "
                                 f"{zenoh_message(e)}") from e
        else:
            config = zenoh.Config()
            config.insert_json5("mode", '"peer"')
            config.insert_json5("scouting/multicast/enabled", "false")
        if self.listen:
            config.insert_json5("listen/endpoints", json.dumps(list(self.listen)))
        if self.connect:
            config.insert_json5("connect/endpoints", json.dumps(list(self.connect)))
        return config


def open_session(network: NetworkConfig) -> zenoh.Session:
    """This process's zenoh session (use it with `with`). Zenoh reads ZENOH_RUNTIME when
    its first session opens; a user's own setting wins over RUNTIME_THREADS."""
    os.environ.setdefault("ZENOH_RUNTIME", RUNTIME_THREADS)
    config = network.zenoh_config()
    try:
        return zenoh.open(config)
    except zenoh.ZError as e:  # e.g. an endpoint it cannot listen on
        raise ClusterError(f"cannot open a zenoh session (--listen {list(network.listen)}, "
                           f"--connect {list(network.connect)}): {zenoh_message(e)}") from e


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


def session_name(text: str) -> str:
    """An argparse type: a session name (1-32 letters, digits, '_' or '-')."""
    try:
        return check_name("session", text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from e


def add_network_arguments(parser: argparse.ArgumentParser) -> None:
    """The network flags every cavesim process takes."""
    group = parser.add_argument_group("network (zenoh)")
    group.add_argument("--listen", action="append", default=[], metavar="ENDPOINT",
                       help=f"endpoint to listen on, e.g. tcp/127.0.0.1:{DEFAULT_MASTER_PORT} "
                            "(repeatable)")
    group.add_argument("--connect", action="append", default=[], metavar="ENDPOINT",
                       help=f"endpoint to connect to, e.g. tcp/10.0.0.1:{DEFAULT_MASTER_PORT} "
                            "(repeatable)")
    group.add_argument("--config", type=Path, dest="zenoh_config", metavar="FILE",
                       help="zenoh JSON5 config file (see config/zenoh/)")
    group.add_argument("--session", default="default", type=session_name,
                       help="session name: the key prefix")
    group.add_argument("--key-file", type=Path, metavar="FILE",
                       help="the session's keys from `cavesim keys`: master.key for the "
                            "master, session.key for nodes and trackers")


def network_from_arguments(args: argparse.Namespace) -> NetworkConfig:
    """The flags' settings, checked: a config file that zenoh cannot read is refused here,
    before anything starts (ValueError, one line)."""
    for endpoint in (*args.listen, *args.connect):
        if "/" not in endpoint:
            raise ValueError(f"endpoint {endpoint!r} must look like tcp/HOST:PORT")
    network = NetworkConfig(tuple(args.listen), tuple(args.connect), args.zenoh_config)
    network.zenoh_config()
    return network


def read_key(path: Path | None) -> Credentials | None:
    """The session's credentials from a --key-file (None without one); ValueError names the
    file and what is wrong."""
    return None if path is None else read_credentials(path)
