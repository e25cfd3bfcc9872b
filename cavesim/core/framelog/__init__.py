"""The master's frame log: every frame's inputs and the checksum the cluster agreed on after
it. `cavesim replay` and `cavesim render` step one engine through the inputs and must
reproduce every checksum bit for bit.

A JSON header line, then one checked record per frame (`log_file.py`: the CRC framing,
crash safety, and where a damaged log stops). The header names the session, the scene's
path and its digest (`scene_digest`, of its content: `cavesim.core.scene.digest`), the
walls and the clock's seed, and the run's planned frames and nominal dt (which fix a
replay's trajectory selection); a log written before the digest was added has none, and a
replay says so.

The log's format version is its own, not the wire's: a wire version moves without touching
a log.

- 4, written: the frame in a layout the log names itself (`version4.py`), read and written
  by the frame codec the wire shares, then the agreed digest and live count.
- 3, read: each record held the frame message as sent, a wire envelope of wire version
  4 to 12 (`_version3.py` reads the old envelope itself).
- 2 added the checks, and 1 is older: both are refused with one line, and replayed by the
  build that wrote them.
"""

from cavesim.core.framelog.log_file import (
    CORRUPT,
    FORMAT,
    FRAME_LOG,
    TORN,
    Damage,
    FrameLogError,
    FrameLogWriter,
    LoggedFrames,
    read_frame_log,
)
from cavesim.core.framelog.version4 import VERSION, LoggedFrame

__all__ = ["CORRUPT", "FORMAT", "FRAME_LOG", "TORN", "VERSION", "Damage", "FrameLogError",
           "FrameLogWriter", "LoggedFrame", "LoggedFrames", "read_frame_log"]
