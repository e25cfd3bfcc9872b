"""Where a wall node's frame goes: the phases it times with a CPU clock, in the order they
come. A node's report of frame k carries frame k's times, and those of the phases that
come after its report (the report itself, the drawing) of frame k - 1; the master keeps
their percentiles per wall (report.json `frame_cost_ms`)."""

from __future__ import annotations

FRAME_PHASES = {  # name -> what its time covers
    "input_wait": "from the frame before reported (and drawn) to this frame's message in "
                  "hand: what the node waited for the others and the master",
    "decode": "the scene frame read out of the message",
    "step": "the emitter and particle passes issued (a GPU may still be running them)",
    "checksum": "the checksum's passes and the wait for the GPU to finish the frame",
    "history": "the frame's checksum tree kept for forensics and deltas",
    "report": "the report of the frame before sealed and handed to Zenoh",
    "render": "the wall of the frame before drawn (or its picture written)",
}
PHASES = tuple(FRAME_PHASES)
MAX_PHASE_US = 2**32 - 1  # a phase's time travels as 32-bit microseconds
NO_COST = (0,) * len(PHASES)  # the times of a report that timed nothing (a join, a resync)
