"""The particle engine on one GL context: emitter and particle streams, checksum."""

from cavesim.engine.checksum import StateChecksum
from cavesim.engine.frame import FrameInput
from cavesim.engine.layout import EMITTER_DTYPE, PARTICLE_DTYPE
from cavesim.engine.particle_system import ParticleSystem

__all__ = ["EMITTER_DTYPE", "PARTICLE_DTYPE", "FrameInput", "ParticleSystem", "StateChecksum"]
