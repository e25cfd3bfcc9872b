"""Which particles a run follows and who each live particle is, frame by frame.

A particle's identity is its birth index: the number of particles appended to the stream
before it since the run started. A run tracks those whose birth index is a multiple of a
stride S and below N·S, with S = max(1, floor(B / N)) for B the births the scene is expected
to make over the run's planned frames: its emitters' rates × dt, times, in a helicopter
scene, the rotor's rate factors along the scripted flight (`Selection`, `expected_births`).

The engine keeps survivors in stream order and appends a frame's new particles after them in
emission order, so after a step the live ids are `ids[survivors] + next_id + arange(born)`
(`BirthIndex`). Which particles survived is predicted on the host exactly as `step_particle`
(shaders/include/physics.glsl) decides it: age + dt < lifetime in float64. Only the
newborns' records are read back each frame; a runaway drop (a step that was not sane, rare)
shows as fewer survivors than predicted, and is then found by matching the new stream's
survivors against the old stream (`_match_survivors`). The recorder (`recording.py`) moves
the index after each step and picks the tracked rows by it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from cavesim.core.drivers import driver_for
from cavesim.core.emitters import EmitterTable
from cavesim.core.errors import TrajectoryError
from cavesim.core.helicopter.inputs import RotorInputs
from cavesim.core.limits import MAX_TRAJECTORIES
from cavesim.core.scene.model import Scene


@dataclass(frozen=True)
class Selection:
    count: int  # N: at most this many particles are tracked
    stride: int  # S

    @classmethod
    def for_run(cls, scene: Scene, count: int, frames: int, dt: float) -> Selection:
        """N particles spread evenly over the births expected in `frames` frames of `dt`."""
        if not 1 <= count <= MAX_TRAJECTORIES:
            raise ValueError(f"trajectories must be in [1, {MAX_TRAJECTORIES}], got {count!r}")
        return cls(count, max(1, int(expected_births(scene, frames, dt) // count)))

    def tracked(self, ids: np.ndarray) -> np.ndarray:
        """Mask of `ids` (birth indices) that are tracked."""
        stride = np.uint64(self.stride)
        return (ids % stride == 0) & (ids < stride * np.uint64(self.count))


def expected_births(scene: Scene, frames: int, dt: float) -> float:
    """Births the scene's emitters are expected to make in `frames` frames of `dt`, the
    capacity aside: their rates, times a helicopter's rate factors frame by frame along its
    scripted flight (as `cavesim.core.helicopter.expected_fill` plays it; no wand), the last
    scripted frame's held past the timeline's end."""
    table = EmitterTable.from_scene(scene)
    if scene.helicopter is None:
        return float(table.rate.astype(np.float64).sum()) * frames * dt
    timeline = scene.helicopter.timeline
    scripted = min(frames, max(1, round(timeline[-1].t / dt) if timeline else 1))
    driver, rotor = driver_for(scene), RotorInputs(scene)
    births = rate = 0.0
    for k in range(1, scripted + 1):
        frame = driver.decode(driver.encode(driver.advance(k * dt, dt, None).frame))
        rate = float(table.frame_rates(rotor.read(frame).rate_factors).sum())
        births += rate * dt
    return births + rate * dt * (frames - scripted)


# host bytes kept per live particle: id (uint64), age (float64), lifetime (float32), class
HOST_BYTES_PER_PARTICLE = 8 + 8 + 4 + 1


class BirthIndex:
    """The birth index, age, lifetime and class of every live particle, in stream order."""

    def __init__(self) -> None:
        self.next_id = 0  # particles appended since the run started
        self.ambiguous_drops = 0  # runaway drops that could not be told from a twin particle
        self.restart()

    def restart(self) -> None:
        """The stream went back to the scene's start state (empty); ids keep counting."""
        self.ids = np.zeros(0, np.uint64)
        self.age = np.zeros(0, np.float64)
        self.lifetime = np.zeros(0, np.float32)
        self.class_id = np.zeros(0, np.uint8)

    def __len__(self) -> int:
        return len(self.ids)

    def advance(self, dt: float, survivors: int, newborns: np.ndarray,
                read_survivors: Callable[[], np.ndarray]) -> None:
        """Follow one step of `dt` after which the stream holds `survivors` old particles
        followed by `newborns` (their records); `read_survivors` gives the survivors' records
        and is called only when a runaway drop must be located."""
        age = self.age + np.float64(np.float32(dt))  # physics.glsl: q.age += double(h)
        alive = age < self.lifetime.astype(np.float64)
        predicted = int(np.count_nonzero(alive))
        if survivors > predicted:
            raise TrajectoryError(f"the engine kept {survivors} particles but only {predicted} "
                                  f"were young enough: the tracker lost the stream")
        if survivors < predicted:
            alive = self._match_survivors(age, alive, read_survivors())
        born = len(newborns)
        self.ids = np.concatenate([self.ids[alive],
                                   np.uint64(self.next_id) + np.arange(born, dtype=np.uint64)])
        self.age = np.concatenate([age[alive], newborns["age"]])
        self.lifetime = np.concatenate([self.lifetime[alive], newborns["lifetime"]])
        self.class_id = np.concatenate([self.class_id[alive], newborns["class_id"]])
        self.next_id += born

    def holds(self, records: np.ndarray) -> bool:
        """Whether `records` (a stream loaded from elsewhere) are the particles this index
        follows: the same count, ages, lifetimes and classes, in order."""
        return (len(records) == len(self.ids)
                and np.array_equal(records["age"], self.age)
                and np.array_equal(records["lifetime"], self.lifetime)
                and np.array_equal(records["class_id"], self.class_id))

    def _match_survivors(self, age: np.ndarray, alive: np.ndarray,
                         records: np.ndarray) -> np.ndarray:
        """Which old particles the survivors' `records` are: the stream keeps their order, so
        they are a subsequence of the young-enough ones with the same (age, lifetime, class);
        taken leftmost. Particles with equal keys next to each other (born in one frame with
        one lifetime and class) cannot be told apart: the later ones count as dropped and
        `ambiguous_drops` counts them."""
        candidates = np.flatnonzero(alive)
        keys = list(zip(age[candidates].tolist(), self.lifetime[candidates].tolist(),
                        self.class_id[candidates].tolist(), strict=True))
        wanted = zip(records["age"].tolist(), records["lifetime"].tolist(),
                     records["class_id"].tolist(), strict=True)
        kept = np.zeros(len(candidates), bool)
        i = 0
        for key in wanted:
            while i < len(keys) and keys[i] != key:
                i += 1
            if i == len(keys):
                raise TrajectoryError("a survivor's record matches no particle of the last "
                                      "frame: the tracker lost the stream")
            kept[i] = True
            i += 1
        for j in np.flatnonzero(~kept):
            twins = [keys[k] for k in (j - 1, j + 1) if 0 <= k < len(keys)]
            self.ambiguous_drops += keys[j] in twins
        out = np.zeros_like(alive)
        out[candidates[kept]] = True
        return out
