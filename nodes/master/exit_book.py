"""The particles that left the field's box, per frame and class, as the run's nodes count
them (`cavesim.gpu.engine.domain_exits`): the master keeps the agreed node's counts of each
frame and warns once, at the first, where the flow beyond the box is not the file's."""

from __future__ import annotations

import logging

from cavesim.core.bounded import BinnedSums
from cavesim.core.scene.model import Scene

log = logging.getLogger("cavesim.master")


class DomainExitBook:
    """Per class: exits in all, the first frame of one, and each frame's (binned past 4,096
    frames). Counted only in a scene whose flow is a grid, and only while the nodes count."""

    def __init__(self, scene: Scene) -> None:
        self.classes = tuple(c.name for c in scene.particle_classes)
        self.field = scene.field if scene.gridded_flow else None
        self.frames = BinnedSums(len(self.classes))
        self.first: dict[str, int] = {}
        self.uncounted = 0  # frames whose agreed report carried no counts
        self.warned = False

    def add(self, k: int, counts: tuple[int, ...]) -> None:
        """Frame k's counts from the node holding the agreed state; () where it counted none
        (its engine path cannot here). Counts of another length are taken as none."""
        if self.field is None:
            return
        if len(counts) != len(self.classes):
            self.uncounted += 1
            counts = (0,) * len(self.classes)
        self.frames.add(counts)
        for name, n in zip(self.classes, counts, strict=True):
            if n and name not in self.first:
                self.first[name] = k
        if any(counts) and not self.warned:
            self.warned = True
            left = ", ".join(f"{n} {name}" for name, n in zip(self.classes, counts, strict=True)
                             if n)
            log.warning("frame %d: particles left the field's box %s .. %s (%s); beyond it "
                        "the flow is %s (out_of_domain), not the field's. report.json counts "
                        "every frame's (domain_exits)", k, list(self.field.box_min),
                        list(self.field.box_max), left, _beyond(self.field.out_of_domain.value))

    def summary(self) -> dict:
        """report.json's domain_exits ({} without a grid)."""
        if self.field is None:
            return {}
        return {
            "box_min": list(self.field.box_min), "box_max": list(self.field.box_max),
            "out_of_domain": self.field.out_of_domain.value,
            "classes": list(self.classes),
            "total": dict(zip(self.classes, self.frames.totals, strict=True)),
            "first_frame": self.first,
            "frames_uncounted": self.uncounted,
            # per bin of `per_frame_stride` frames (1 up to 4,096 frames), each class's exits
            "per_frame": self.frames.bins(),
            "per_frame_stride": self.frames.stride,
        }


def _beyond(out_of_domain: str) -> str:
    return {"clamp": "the nearest boundary node's", "zero": "still air"}[out_of_domain]
