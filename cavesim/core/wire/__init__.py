"""The wire between master and wall nodes: key expressions, credentials and binary
messages."""

from cavesim.core.wire.credentials import Credentials
from cavesim.core.wire.key_expressions import SessionKeys
from cavesim.core.wire.messages import (
    BlockQuery,
    BlockReply,
    BlockRequest,
    Command,
    ControlMessage,
    DisplayMessage,
    Envelope,
    FrameMessage,
    HeadState,
    InfoMessage,
    InfoRequest,
    ReportMessage,
    SnapshotChunk,
    SnapshotHeader,
    StateRequest,
    TrackingMessage,
    WandState,
    decode,
    decode_envelope,
    encode,
)

__all__ = ["BlockQuery", "BlockReply", "BlockRequest", "Command", "ControlMessage",
           "Credentials", "DisplayMessage", "Envelope", "FrameMessage", "HeadState",
           "InfoMessage", "InfoRequest", "ReportMessage",
           "SessionKeys", "SnapshotChunk", "SnapshotHeader", "StateRequest", "TrackingMessage",
           "WandState", "decode", "decode_envelope", "encode"]
