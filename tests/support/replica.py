"""A wall node's engine in a process of its own, for the determinism tests.

Runs in a `spawn`ed child: a fresh interpreter with its own EGL context and GPU memory.
"""

from __future__ import annotations

import hashlib

import numpy as np


def run_replica(scene_data: dict, frames: int, matrix_seed: int, dt: float = 1 / 60):
    """Step a scene `frames` times; return per-frame checksums and the final state's hash."""
    from cavesim.core.random_texture import draw_transform
    from cavesim.core.scene import parse_scene
    from cavesim.gpu.engine import FrameInput, ParticleSystem
    from cavesim.gpu.gl.context import create_context

    scene = parse_scene(scene_data, name="replica")
    ctx = create_context()
    system = ParticleSystem(ctx, scene)
    rng = np.random.default_rng(matrix_seed)
    digests, counts = [], []
    for _ in range(frames):
        system.step(FrameInput(dt, draw_transform(rng, scene.random_texture_size)))
        state = system.checksum()
        digests.append(state.digest)
        counts.append(state.particles)
    final = hashlib.sha256(system.read_particles().tobytes() + system.read_emitters().tobytes())
    error = ctx.error
    ctx.release()
    return {"digests": digests, "counts": counts, "state_sha256": final.hexdigest(),
            "gl_error": error}
