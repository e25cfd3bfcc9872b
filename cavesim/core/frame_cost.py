"""Where a node's frame goes: the phases it times, in the order they come, each with a CPU
clock or a GPU timer. A node's report of frame k carries frame k's times, and those of the
phases that come after its report (the report itself, the drawing) of frame k - 1; the
master keeps their percentiles per node (report.json `frame_cost_ms`). The GPU's times
run beside the CPU's (the CPU issues the passes, then waits in `gpu_sync`), so the CPU
phases add up to the frame and the GPU phases to the GPU's share of it."""

from __future__ import annotations

FRAME_PHASES = {  # name -> (clock, what its time covers)
    "input_wait": ("CPU", "from the frame before reported (and drawn) to this frame's "
                          "message in hand: what the node waited for the others and the master"),
    "decode": ("CPU", "the scene frame read out of the message"),
    "step": ("CPU", "the emitter and particle passes issued"),
    "emitter_pass": ("GPU", "the emitter stream's update and its new particles appended"),
    "particle_pass": ("GPU", "the live particles stepped and the survivors kept"),
    "checksum_pass": ("GPU", "the state reduced to its digest"),
    "gpu_sync": ("CPU", "waiting for the GPU (a polled fence): the frame's results read"),
    "checksum": ("CPU", "the checksum's passes issued and its digest read"),
    "history": ("CPU", "the frame's checksum tree kept for forensics and deltas"),
    "report": ("CPU", "the report of the frame before sealed and handed to Zenoh"),
    "render": ("CPU", "the walls of the frame before drawn (or their pictures written)"),
}
PHASES = tuple(FRAME_PHASES)
NOT_TIMED_US = 2**32 - 1  # a GPU phase of a frame whose passes were not timed (sampled)
MAX_PHASE_US = NOT_TIMED_US - 1  # a phase's time travels as 32-bit microseconds
GPU_PHASES = tuple(name for name, (clock, _) in FRAME_PHASES.items() if clock == "GPU")
NO_COST = (0,) * len(PHASES)  # the times of a report that timed nothing (a join, a resync)
