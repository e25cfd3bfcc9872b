"""The head and wand a tracker bridge publishes, kept from one DTrack datagram to the next.

A target whose body a datagram lacks, or reports as not tracked, keeps its last pose (the
datagram counts as missing it); until it is first seen it has the wire's default pose. A
Flystick's buttons and joystick are taken whenever it is reported, tracked or not.
"""

from __future__ import annotations

import time

from cavesim.core.tracking.dtrack import Body, Datagram, Flystick
from cavesim.core.tracking.mapping import Target, Tracked, TrackerMapping
from cavesim.core.wire.payloads.poses import HeadState, TrackingMessage, WandState

WAND_AXES = 4  # controllers a WandState carries; a Flystick's further ones are dropped


class TrackingState:
    """The latest head and wand in the CAVE's room, updated datagram by datagram."""

    def __init__(self, mapping: TrackerMapping) -> None:
        self.mapping = mapping
        self.head = HeadState()
        self.wand = WandState()

    def update(self, datagram: Datagram) -> tuple[str, ...]:
        """Take the datagram's poses; return the targets it was missing ("head", "wand")."""
        missing = []
        head, wand = self.mapping.head, self.mapping.wand
        if head is not None:
            body = _find(datagram, head)
            if body is not None and body.tracked:
                self.head = HeadState(*self.mapping.pose(head, body))
            else:
                missing.append("head")
        if wand is not None:
            body = _find(datagram, wand)
            position, orientation = self.wand.position, self.wand.orientation
            if body is not None and body.tracked:
                position, orientation = self.mapping.pose(wand, body)
            else:
                missing.append("wand")
            buttons, axes = self.wand.buttons, self.wand.axes
            if isinstance(body, Flystick):
                buttons = body.buttons
                axes = (*body.controllers[:WAND_AXES],
                        *(0.0,) * (WAND_AXES - len(body.controllers)))
            self.wand = WandState(position, orientation, buttons, axes)
        return tuple(missing)

    def message(self, frame: int) -> TrackingMessage:
        return TrackingMessage(frame, self.head, self.wand, time.time_ns())


def _find(datagram: Datagram, target: Target) -> Body | None:
    found = datagram.flysticks if target.tracked is Tracked.FLYSTICK else datagram.bodies
    return found.get(target.id)
