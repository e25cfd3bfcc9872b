"""The wire between master and wall nodes: key expressions and binary messages."""

from cavesim.wire.keys import SessionKeys
from cavesim.wire.messages import (
    Command,
    ControlMessage,
    FrameMessage,
    HeadState,
    InfoMessage,
    ReportMessage,
    StateMessage,
    TrackingMessage,
    WandState,
    decode,
    encode,
)

__all__ = ["Command", "ControlMessage", "FrameMessage", "HeadState", "InfoMessage", "ReportMessage",
           "SessionKeys", "StateMessage", "TrackingMessage", "WandState", "decode", "encode"]
