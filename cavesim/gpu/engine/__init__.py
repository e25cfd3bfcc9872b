"""The particle engine on one GL context: emitter and particle streams, checksum."""

from cavesim.core.digest.shape import StateChecksum
from cavesim.core.frame import FrameInput
from cavesim.core.records import EMITTER_DTYPE, PARTICLE_DTYPE
from cavesim.gpu.engine.particle_system import ParticleSystem

__all__ = ["EMITTER_DTYPE", "PARTICLE_DTYPE", "FrameInput", "ParticleSystem", "StateChecksum"]
