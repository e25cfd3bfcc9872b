"""What confirming a resync's state costs at N particles (`cavesim bench --resync`), in this
process on one context: the confirmer reads its live particle stream from the GPU and
hashes it (a DIGEST block question, `nodes/blocks.py`), the receiver hashes the chunks it
received (`nodes/wall/snapshots.py`); SHA-256 is the digest, BLAKE2b-256 is timed beside it.
"""

from __future__ import annotations

import hashlib
import statistics
import time
from collections.abc import Callable

from rich.console import Console

from cavesim.core.digest.records_digest import records_digest
from cavesim.core.digest.shape import PARTICLES
from cavesim.core.records import PARTICLE_BYTES
from cavesim.core.scene import Scene
from cavesim.core.wire.payloads.state_transfer import BlockQuery, BlockRequest

REPEATS = 5  # timed runs of each step (medians)


def confirmation_cost(scene: Scene, console: Console) -> dict:
    """Medians at the scene's capacity, all live: the GPU read of the particle stream, its
    SHA-256 (the records digest) and BLAKE2b on the host, and a confirmer's whole DIGEST
    answer (read and hash, a piece at a time); each printed as it is measured."""
    from cavesim.gpu.engine import ParticleSystem
    from cavesim.gpu.gl.context import create_context, gpu_of
    from cavesim.tools.bench.workload import preload
    from nodes.blocks import answer

    ctx = create_context()
    system = ParticleSystem(ctx, scene)
    try:
        system.write_particles(preload(scene, scene.capacity, None))
        live = system.live_count
        data = system.read_particle_chunk(0, live)
        whole = BlockRequest(0, "bench", "0" * 32, BlockQuery.DIGEST, PARTICLES)
        system.tree_state()  # the checksum's tree, which any answer reads first, is made
        steps = {
            "gpu_read_ms": lambda: system.read_particle_chunk(0, live),
            "sha256_ms": lambda: records_digest(PARTICLES, live, data),
            "blake2b_ms": lambda: hashlib.blake2b(data, digest_size=32).digest(),
            "confirmer_answer_ms": lambda: answer(system, whole, "bench"),
        }
        figures = {"particles": live, "bytes": live * PARTICLE_BYTES, "repeats": REPEATS,
                   "renderer": gpu_of(ctx)["renderer"]}
        for name, step in steps.items():
            figures[name] = round(_median_ms(step), 2)
            console.print(f"confirmation at {live:,} particles: {name[:-3].replace('_', ' ')} "
                          f"{figures[name]} ms", markup=False, highlight=False)
    finally:
        system.release()
        ctx.release()
    megabytes = figures["bytes"] / 1e6
    figures["sha256_mb_per_s"] = round(megabytes / (figures["sha256_ms"] / 1e3))
    figures["blake2b_mb_per_s"] = round(megabytes / (figures["blake2b_ms"] / 1e3))
    return figures


def _median_ms(step: Callable[[], object]) -> float:
    times = []
    for _ in range(REPEATS):
        started = time.perf_counter()
        step()
        times.append(time.perf_counter() - started)
    return statistics.median(times) * 1e3
