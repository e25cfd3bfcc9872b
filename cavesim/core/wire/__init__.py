"""The wire between master and wall nodes: key expressions, credentials, and binary
messages (the envelope around every message, and the payloads in it)."""

from cavesim.core.wire.credentials import Credentials
from cavesim.core.wire.envelope import Envelope, decode, decode_envelope, encode
from cavesim.core.wire.key_expressions import SessionKeys
from cavesim.core.wire.payloads.from_master import (
    Command,
    ControlMessage,
    FrameMessage,
    InfoRequest,
)
from cavesim.core.wire.payloads.from_nodes import DisplayMessage, InfoMessage, ReportMessage
from cavesim.core.wire.payloads.poses import (
    HeadState,
    SessionControls,
    TrackingMessage,
    WandState,
)
from cavesim.core.wire.payloads.state_transfer import (
    BlockQuery,
    BlockReply,
    BlockRequest,
    SnapshotChunk,
    SnapshotHeader,
    StateRequest,
)

__all__ = ["BlockQuery", "BlockReply", "BlockRequest", "Command", "ControlMessage",
           "Credentials", "DisplayMessage", "Envelope", "FrameMessage", "HeadState",
           "InfoMessage", "InfoRequest", "ReportMessage", "SessionControls", "SessionKeys",
           "SnapshotChunk", "SnapshotHeader", "StateRequest", "TrackingMessage", "WandState",
           "decode", "decode_envelope", "encode"]
