"""The whole engine in numpy: the reference of `ParticleSystem`, frame for frame.

State is kept in the GPU's stream order, so a test can compare particle i with particle i,
and computed by one of two sets of kernels (`kernels.py`): the twin's own in `dtype`
(float64: the reference; float32: the CPU baseline), or for a scene in portable arithmetic
the portable float32 ones, which give the GPU's bits.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial

import numpy as np

from cavesim.core.counters import Counts, TwinStep, twin_counts
from cavesim.core.digest.shape import EMITTERS
from cavesim.core.emitters import EMIT_BATCH, EmitterTable
from cavesim.core.features.feature import NO_FRAME, FrameState
from cavesim.core.features.registry import FeatureData, features_of
from cavesim.core.fields.snapshot_time import FIRST_SNAPSHOT
from cavesim.core.frame import FrameInput
from cavesim.core.helicopter.inputs import RotorInputs
from cavesim.core.limits import RUNAWAY, SPEED_LIMIT
from cavesim.core.portable.forces import PortableForces
from cavesim.core.position import low_code, low_part, split_position
from cavesim.core.random_texture import random_words
from cavesim.core.records import EMITTER_DTYPE, PARTICLE_DTYPE
from cavesim.core.scene.model import Arithmetic, Scene
from cavesim.core.scene_frame import NOTHING_MOVES, SceneFrame
from cavesim.core.substeps import NO_SUBSTEPS, SubstepCounts
from cavesim.core.twin.emission import emission_order, update_emitters
from cavesim.core.twin.forces import ForceModel
from cavesim.core.twin.kernels import PORTABLE, Kernels, reference_kernels


@dataclass
class TwinParticles:
    pos: np.ndarray  # (N, 3) dtype: hi, the record's float32 position (float64: all of it)
    pos_low: np.ndarray  # (N, 3) float32: what pos leaves out, as the record keeps it
    vel: np.ndarray  # (N, 3) dtype
    age: np.ndarray  # (N,) float64, as on the GPU
    lifetime: np.ndarray  # (N,) float32
    class_id: np.ndarray  # (N,) uint8

    @classmethod
    def from_records(cls, records: np.ndarray, dtype) -> TwinParticles:
        return cls(records["pos"].astype(dtype), low_part(records["pos"], records["pos_low"]),
                   records["vel"].astype(dtype), records["age"].copy(),
                   records["lifetime"].copy(), records["class_id"].copy())

    def position(self) -> np.ndarray:
        """pos + pos_low in pos's dtype (exact in float64)."""
        return self.pos + self.pos_low.astype(self.pos.dtype)

    def records(self) -> np.ndarray:
        out = np.zeros(len(self.age), dtype=PARTICLE_DTYPE)
        if self.pos.dtype == np.float64:
            out["pos"], out["pos_low"] = split_position(self.position())
        else:
            out["pos"], out["pos_low"] = self.pos, low_code(self.pos, self.pos_low)
        out["vel"], out["age"] = self.vel, self.age
        out["lifetime"], out["class_id"] = self.lifetime, self.class_id
        return out

    def select(self, keep: np.ndarray) -> TwinParticles:
        return TwinParticles(*(getattr(self, name)[keep] for name in _FIELDS))

    @classmethod
    def concatenate(cls, parts: list[TwinParticles]) -> TwinParticles:
        return cls(*(np.concatenate([getattr(p, name) for p in parts]) for name in _FIELDS))


_FIELDS = ("pos", "pos_low", "vel", "age", "lifetime", "class_id")


def below(x: np.ndarray, limit: float) -> np.ndarray:
    """Rows of x whose every component is below `limit` as float32 (physics.glsl's `below`:
    NaN is not)."""
    with np.errstate(invalid="ignore"):
        return (np.abs(x) < np.float32(limit)).all(axis=1)


class TwinSystem:
    """numpy twin of `cavesim.gpu.engine.ParticleSystem` for one scene.

    With `dtype` None, a scene in portable arithmetic gets the portable kernels (float32, the
    GPU's bits) and any other the float64 reference; a given `dtype` always means the
    reference kernels in it.
    """

    def __init__(self, scene: Scene, dtype=None) -> None:
        self.scene = scene
        portable = dtype is None and scene.arithmetic is Arithmetic.PORTABLE
        self.kernels: Kernels = PORTABLE if portable else reference_kernels(
            np.dtype(dtype or np.float64).type)
        self.dtype = self.kernels.dtype
        self.table = EmitterTable.from_scene(scene)
        self.rotor_inputs = RotorInputs(scene) if scene.helicopter is not None else None
        self.features = features_of(scene)
        drawn = len(self.table) or any(f.draws_random for f in self.features)
        self.random = random_words(scene.seed, scene.random_texture_size) if drawn else None
        self.data = FeatureData(scene, self.random)
        self.tracer_classes = np.array(scene.tracer_classes or (False,))
        self.integrate = self.kernels.integrators[scene.integrator]
        self.trace = self.kernels.tracers[scene.method_for_tracers]
        self._substeps = NO_SUBSTEPS  # what the adaptive tracers did in the step
        if scene.tracers_take_substeps:
            self.trace = partial(self.trace, tolerance=np.float32(scene.tracer_tolerance),
                                 record=self._record_substeps)
        self.following = any(e.follow_helicopter for e in scene.emitters)
        self.particles = TwinParticles.from_records(np.zeros(0, PARTICLE_DTYPE), self.dtype)
        self.emitters = np.zeros(len(self.table), dtype=EMITTER_DTYPE)
        self._counts = self._zero_counts()  # the last step's counters

    def _record_substeps(self, counts: SubstepCounts) -> None:
        self._substeps = counts

    def counters(self) -> Counts:
        """The last step's counters by name, every row the scene counts, as the GPU counts
        them (`ParticleSystem.counters`; each row's `twin` in cavesim/core/counters.py)."""
        return dict(self._counts)

    def _zero_counts(self) -> Counts:
        """Every counter 0: a state written, not stepped into."""
        none, nowhere = np.zeros(0, dtype=bool), self.particles.pos[:0]
        return twin_counts(self.scene, TwinStep(self, none.astype(np.uint8), nowhere, nowhere,
                                                none, none, NO_SUBSTEPS, 0, 0))

    @property
    def live_count(self) -> int:
        return len(self.particles.age)

    def write_particles(self, records: np.ndarray) -> None:
        self.particles = TwinParticles.from_records(records, self.dtype)
        self._counts = self._zero_counts()

    # the engine's reads, for code that reads either (the trajectory recorder)
    def dropped(self) -> int:
        """New particles the last step dropped because the capacity was full (0 after a
        load)."""
        return self._counts.get("capacity_drops", (0,))[0]

    def read_emitters(self) -> np.ndarray:
        """A copy of the emitter stream (EMITTER_DTYPE)."""
        return self.emitters.copy()

    def read_particle_chunk(self, first: int, count: int) -> bytes:
        """Records [first, first + count) of the live particle stream, as bytes."""
        return self.particles.select(slice(first, first + count)).records().tobytes()

    def read_records(self, stream: int, indices: np.ndarray) -> bytes:
        """Records `indices` (ascending, live) of `stream` (PARTICLES or EMITTERS), as bytes
        in that order."""
        indices = np.asarray(indices, dtype=np.int64)
        if stream == EMITTERS:
            return self.emitters[indices].tobytes()
        return self.particles.select(indices).records().tobytes()

    def forces_for(self, class_id: np.ndarray, state: FrameState = NO_FRAME,
                   seen: dict | None = None) -> ForceModel | PortableForces:
        """The force model of particles of the given classes in the frame `state`: each
        feature's terms, and `seen`, what they see besides the flow this step."""
        terms = dict(seen or {})
        for feature in self.features:
            terms |= feature.force_terms(self.scene, self.data.get(feature.name),
                                         self.kernels, class_id, state)
        return self.kernels.forces(**terms)

    def step(self, frame: FrameInput, scene: SceneFrame = NOTHING_MOVES) -> None:
        """Advance one frame exactly as the GPU does (survivors, then new particles)."""
        rotor = self.rotor_inputs.read(scene) if self.rotor_inputs is not None else None
        q = self.particles
        age = q.age + np.float64(frame.dt)
        alive = age < q.lifetime.astype(np.float64)
        state = FrameState(frame, rotor, scene.field_time or FIRST_SNAPSHOT)
        forces = self.forces_for(q.class_id, state)
        seen = {}
        for feature in self.features:
            seen |= feature.seen(self.scene, self.data.get(feature.name), self.kernels, self,
                                 forces, state)
        if seen:
            forces = self.forces_for(q.class_id, state, seen)
        sane = below(q.vel, SPEED_LIMIT)
        pos, low, vel = self._move(q, self.dtype(frame.dt), forces)
        sane &= below(pos, RUNAWAY) & below(vel, SPEED_LIMIT)
        alive &= sane
        moved = TwinParticles(pos, low, vel, age, q.lifetime, q.class_id).select(alive)
        new = self._emit(frame, len(moved.age), rotor)
        self.particles = TwinParticles.concatenate([moved, *new])
        self._counts = twin_counts(self.scene, TwinStep(
            self, q.class_id, q.pos, pos, sane, alive, self._substeps,
            int(self.emitters["count"].sum()), self.live_count))

    def _move(self, q: TwinParticles, h, forces: ForceModel | PortableForces
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(pos, pos_low, vel) after one step and the bounce. The portable kernels keep the
        position as the GPU does, hi + low (position.glsl: the forces' position_low is its
        step_position_low; a bounce that sets z drops low.z; the record rounds low to its
        byte); the reference moves its whole position in its own dtype."""
        portable = isinstance(forces, PortableForces)
        if portable:
            forces.position_low = q.pos_low
            start = q.pos
        else:
            start = q.position()
        pos, vel = self._stepped(start, q, h, forces)
        low = forces.position_low if portable else np.zeros_like(q.pos_low)
        moved = pos
        for feature in self.features:  # a bounce pushes a particle back onto the ground
            pos, vel = feature.after_move(self.scene, self.data.get(feature.name),
                                          self.kernels, pos, vel)
        low[:, 2] = np.where(pos[:, 2] != moved[:, 2], np.float32(0.0), low[:, 2])
        if portable:
            low = low_part(pos, low_code(pos, low))
        return pos, low, vel

    def _stepped(self, start: np.ndarray, q: TwinParticles, h,
                 forces: ForceModel | PortableForces) -> tuple[np.ndarray, np.ndarray]:
        """(pos, vel) after each particle's step: by the integrator, or a tracer class's by
        its tracer method (physics.glsl's branch in advance). The two groups step apart,
        each with the forces of its rows; a portable model gets its rows' low parts back."""
        tracer = self.tracer_classes[np.minimum(q.class_id, len(self.tracer_classes) - 1)]
        self._substeps = NO_SUBSTEPS  # a step without tracers takes no substeps
        if not tracer.any():
            return self.integrate(start, q.vel, h, forces)
        inertial, tracers = forces.of_rows(~tracer), forces.of_rows(tracer)
        pos, vel = np.empty_like(start), np.empty_like(q.vel)
        pos[~tracer], vel[~tracer] = self.integrate(start[~tracer], q.vel[~tracer], h, inertial)
        pos[tracer], vel[tracer] = self.trace(start[tracer], h, tracers)
        if isinstance(forces, PortableForces):
            forces.position_low = np.empty_like(forces.position_low)
            forces.position_low[~tracer] = inertial.position_low
            forces.position_low[tracer] = tracers.position_low
        return pos, vel

    def _emit(self, frame: FrameInput, survivors: int, rotor) -> list[TwinParticles]:
        if not len(self.table):
            return []
        factors = None if rotor is None else rotor.rate_factors
        self.emitters = update_emitters(self.emitters, self.table, frame.dt,
                                        self.scene.capacity, factors)
        room = self.scene.capacity - survivors
        new = []
        for e, first, n in emission_order(self.emitters["count"], EMIT_BATCH):
            if room <= 0:
                break
            serials = (self.emitters["serial"][e].astype(np.uint64) + first
                       + np.arange(min(n, room), dtype=np.uint64)) & 0xFFFFFFFF
            origin = rotor.origins[e] if self.following else None
            records = self.kernels.spawn(self.table, e, serials, self.random,
                                         frame.random_transform, origin=origin)
            new.append(TwinParticles.from_records(records, self.dtype))
            room -= len(records)
        return new
