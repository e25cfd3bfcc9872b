"""How large a scene may be: bounds that every GL 4.3 driver can compile and run.

The scene loader enforces them; the engine's programs are specialized up to them, and the
portability gate (`cavesim.shader_gate`) compiles every program at these extremes.
"""

MAX_PARTICLE_CLASSES = 64  # one uniform float array: 256 components padded, GL 4.3 allows 512+
MAX_EMITTERS = 4096  # columns of the emitter table texture (GL 4.3: at least 16384)
RANDOM_TEXTURE_SIZE_RANGE = (16, 4096)  # a power of two; 4096 is below every GL 4.3 limit
