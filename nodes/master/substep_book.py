"""The substeps adaptive tracers take, per frame, as the run's nodes count them
(`ParticleSystem.tracer_substeps`): the master keeps the agreed node's counts of each frame.
The counts follow from the agreed state of the frame before and the frame's inputs, so
every node that agrees and counts holds them."""

from __future__ import annotations

from cavesim.core.bounded import BinnedSums
from cavesim.core.scene.model import Scene
from cavesim.core.substeps import SUBSTEP_COUNTS, SubstepCounts

REPORT_KEY = "tracer_substeps"  # report.json's section


class SubstepBook:
    """Tracers stepped, substeps taken and retaken in all and per frame (binned past 4,096
    frames), and the most one tracer took in a frame, with that frame. Kept only in a scene
    whose tracers step in substeps, and only while the nodes count."""

    def __init__(self, scene: Scene) -> None:
        self.kept = scene.tracers_take_substeps
        self.frames = BinnedSums(SUBSTEP_COUNTS - 1)  # tracers, taken, retaken
        self.most = (0, 0)  # (substeps, frame)
        self.uncounted = 0  # frames whose agreed report carried no counts

    def add(self, k: int, counts: tuple[int, ...]) -> None:
        """Frame k's counts from the node holding the agreed state; () where it counted none
        (its engine path cannot here)."""
        if not self.kept:
            return
        if len(counts) != SUBSTEP_COUNTS:
            self.uncounted += 1
            return
        frame = SubstepCounts(*counts)
        self.frames.add((frame.tracers, frame.taken, frame.retaken))
        if frame.most > self.most[0]:
            self.most = (frame.most, k)

    def summary(self) -> dict:
        """report.json's tracer_substeps ({} where the tracers take no substeps)."""
        if not self.kept:
            return {}
        tracers, taken, retaken = self.frames.totals
        return {
            "tracer_frames": tracers,  # a tracer stepped one frame: one
            "taken": taken,
            "retaken": retaken,
            "per_tracer_frame": round(taken / tracers, 3) if tracers else None,
            "most": self.most[0],  # substeps one tracer took in one frame
            "most_frame": self.most[1],
            "frames_uncounted": self.uncounted,
            # per bin of `per_frame_stride` frames: tracers, taken, retaken
            "per_frame": self.frames.bins(),
            "per_frame_stride": self.frames.stride,
        }
