"""The wire between master and wall nodes: key expressions and binary messages."""

from cavesim.core.wire.keys import SessionKeys
from cavesim.core.wire.messages import (
    Command,
    ControlMessage,
    DisplayMessage,
    FrameMessage,
    HeadState,
    InfoMessage,
    ReportMessage,
    SnapshotChunk,
    SnapshotHeader,
    TrackingMessage,
    WandState,
    decode,
    encode,
)

__all__ = ["Command", "ControlMessage", "DisplayMessage", "FrameMessage", "HeadState",
           "InfoMessage", "ReportMessage", "SessionKeys", "SnapshotChunk", "SnapshotHeader",
           "TrackingMessage", "WandState", "decode", "encode"]
