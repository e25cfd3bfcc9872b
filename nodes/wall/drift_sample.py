"""A wall node's side of the mixed-hardware tolerance mode: the drift sample it reads after
each step and sends with its report, and the two faults that make a node drift the way a
GPU with other arithmetic would (`jitter`) or far beyond any tolerance (`shove`), so the
mode can be tested on one kind of GPU.
"""

from __future__ import annotations

import numpy as np

from cavesim.core.drift import DriftSample, sample_indices
from cavesim.core.records import PARTICLE_DTYPE
from cavesim.gpu.engine import ParticleSystem

WHOLE_STREAM_READ = 4  # x the sample: a stream this short is read in one piece
SHOVE_METRES = 0.1  # how far `shove` moves the first particle: 100 x the default tolerance


def read_drift_sample(system: ParticleSystem, size: int) -> DriftSample:
    """Positions and velocities of the records `sample_indices` names in the live stream."""
    live = system.live_count
    indices = sample_indices(live, size)
    if live <= WHOLE_STREAM_READ * size:
        records = system.read_particles()[indices]
    else:  # one small read per record: a few KiB instead of the whole stream
        data = b"".join(system.read_particle_chunk(int(i), 1) for i in indices)
        records = np.frombuffer(data, PARTICLE_DTYPE)
    return DriftSample.of(records["pos"], records["vel"])


def jitter(system: ParticleSystem) -> None:
    """Every live particle's position one float32 step (ULP) up on each axis: the size of
    difference another GPU's rounding makes in one frame."""
    particles = system.read_particles()
    particles["pos"] = np.nextafter(particles["pos"], np.float32(np.inf))
    system.write_particles(particles)


def shove(system: ParticleSystem) -> None:
    """The first live particle (in every drift sample) moved SHOVE_METRES along x."""
    particles = system.read_particles()
    if len(particles):
        particles["pos"][0, 0] += np.float32(SHOVE_METRES)
        system.write_particles(particles)


DRIFT_FAULTS = {"jitter": jitter, "shove": shove}  # fault kind -> what the node does at it
