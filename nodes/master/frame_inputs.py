"""What goes into a frame, drawn and sampled once, by the master alone: the random-texture
matrix from the clock's generator, the head (tracked, or scripted while no tracker has
spoken), the wand, and the scene driver's state; the user's pause and reset act here.

`FrameInputs.make(k, asked)` is frame k's message; `nodes/master/process.py` publishes it
and holds the barrier. Nothing here waits.
"""

from __future__ import annotations

import logging
import time
from dataclasses import replace

import numpy as np

from cavesim.core.drivers import DriverStep, driver_for
from cavesim.core.frame import FrameInput
from cavesim.core.random_texture import draw_transform
from cavesim.core.scene.model import Scene
from cavesim.core.tracking.scripted_head import ScriptedHead
from cavesim.core.wire import FrameMessage, TrackingMessage, WandState
from cavesim.core.wire.payloads.poses import MAX_TRACKING_AGE
from nodes.master.run_record import RunRecord, UserAction
from nodes.master.user_requests import Asked

log = logging.getLogger("cavesim.master")


class FrameInputs:
    """Each frame's inputs for a scene, stepped `dt` a frame, from `clock_seed`."""

    def __init__(self, scene: Scene, dt: float, clock_seed: int, link,
                 record: RunRecord) -> None:
        """`link`: where the latest tracking message is (its `tracking`)."""
        self.scene, self.dt = scene, dt
        self.link, self.record = link, record
        self.driver = driver_for(scene)
        self.matrix_rng = np.random.Generator(np.random.PCG64(clock_seed))
        self.head = ScriptedHead()
        self.paused = False
        self.steps = 0  # of simulation time since the start or the last reset
        self.last_step: DriverStep | None = None  # the scene's state a paused frame holds
        self.tracking_quiet = False  # the latest tracking message is older than allowed

    def make(self, k: int, asked: Asked) -> FrameMessage:
        """Frame k's inputs, drawn and sampled once: the clock's matrix, the tracked head
        (or the script's when no tracker has spoken), and the scene driver's state.

        A reset starts the scene over: a new driver at simulation time 0, and the frame
        tells every node to go back to the start state before it steps (its step is the
        scene's first, also in a pause, which then holds that state). A paused frame holds
        simulation time: dt is 0, which leaves every particle where it is and emits none,
        and the scene's state is the last frame's; the frame still goes through the
        barrier, so the checksums keep proving the walls equal, the head still moves, and
        the frame log keeps one record per frame."""
        if asked.reset:
            self.driver, self.steps = driver_for(self.scene), 0
            self.record.user_actions.append(UserAction(k, "reset", asked.by))
            log.info("frame %d: %s reset the scene", k, asked.by or "the user")
        paused = asked.paused and self.last_step is not None  # a pause holds a state made
        if paused != self.paused:
            self.paused = paused
            self.record.user_actions.append(UserAction(k, "pause" if paused else "resume",
                                                       asked.by))
        tracked = self.tracked()
        if paused and not asked.reset:
            self.record.paused_frames += 1
            step, dt = self.last_step, 0.0
        else:
            self.steps += 1
            step, dt = self.driver.advance(self.steps * self.dt, self.dt,
                                           tracked.wand if tracked else None), self.dt
            self.record.clamped_inputs += step.clamped
            self.last_step = step
        if step.flight is not None:
            self.record.add_flight(step.flight)
        inputs = FrameInput(dt, draw_transform(self.matrix_rng, self.scene.random_texture_size))
        head = tracked.head if tracked else self.head.at(self.steps * self.dt)
        return FrameMessage(k, inputs, step.wand, self.driver.encode(step.frame), head,
                            asked.reset)

    def tracked(self) -> TrackingMessage | None:
        """The latest tracking message, or None before any. One sent longer ago than
        MAX_TRACKING_AGE (the tracker went quiet) keeps its head but releases the wand:
        no button stays pressed and no stick stays pushed after the tracker stops."""
        tracked = self.link.tracking
        if tracked is None:
            return None
        quiet = time.time() - tracked.sent_ns / 1e9 > MAX_TRACKING_AGE
        if quiet != self.tracking_quiet:
            self.tracking_quiet = quiet
            if quiet:
                log.warning("tracking went quiet (nothing for %.0f s): the head holds its "
                            "last pose, the wand is released", MAX_TRACKING_AGE)
            else:
                log.info("tracking is back")
        return replace(tracked, wand=WandState()) if quiet else tracked
