"""Emission (twin of shaders/particles/emitter_update.glsl and emit.glsl)."""

from __future__ import annotations

import numpy as np

from cavesim.core.emitters import EmitterTable
from cavesim.core.random_texture import random_texels, unit_float
from cavesim.core.records import EMITTER_DTYPE, PARTICLE_DTYPE


def update_emitters(state: np.ndarray, table: EmitterTable, dt: np.float32,
                    capacity: int, factors: np.ndarray | None = None) -> np.ndarray:
    """Next emitter state: accumulate rate·dt in float64, take the whole part as the count."""
    accumulated = state["accumulator"] + table.frame_rates(factors) * np.float64(dt)
    whole = np.floor(accumulated)
    nxt = np.zeros(len(state), dtype=EMITTER_DTYPE)
    nxt["accumulator"] = accumulated - whole
    nxt["count"] = np.minimum(whole, table.max_emit(dt, capacity, factors)).astype(np.uint32)
    with np.errstate(over="ignore"):
        nxt["serial"] = state["serial"] + state["count"]
    return nxt


def spawn(table: EmitterTable, e: int, serials: np.ndarray, random: np.ndarray,
          transform: np.ndarray, dtype=np.float64, origin=None) -> np.ndarray:
    """New particles of emitter e with the given emission serials (PARTICLE_DTYPE).

    `origin`: the frame's emission origin where the scene's emitters follow the helicopter.
    """
    r0, r1 = random_texels(random, table.random_base[e], serials, transform)
    u0 = unit_float(r0).astype(dtype)
    u1 = unit_float(r1).astype(dtype)
    center = table.position[e].astype(dtype)
    if origin is not None:
        center = np.asarray(origin, np.float32).astype(dtype) + center
    position = center + (u0[:, :3] - 0.5) * table.extent[e]
    versine = u0[:, 3] * dtype(table.versine_spread[e])
    cos_theta = 1 - versine
    sin_theta = np.sqrt(np.maximum(0, versine * (2 - versine)))
    phi = (2 * np.pi) * u1[:, 0]
    direction = ((sin_theta * np.cos(phi))[:, None] * table.tangent[e]
                 + (sin_theta * np.sin(phi))[:, None] * table.bitangent[e]
                 + cos_theta[:, None] * table.axis[e])
    speed = table.speed[e] + table.speed_spread[e] * (2 * u1[:, 1] - 1)
    low, high = table.lifetime[e].astype(dtype)
    out = np.zeros(len(serials), dtype=PARTICLE_DTYPE)
    out["pos"] = position
    out["vel"] = speed[:, None] * direction
    out["lifetime"] = low + (high - low) * u1[:, 2]
    out["class_id"] = table.class_id[e]
    return out


def emission_order(counts: np.ndarray, batch: int) -> list[tuple[int, int, int]]:
    """(emitter, first, n) runs in the GPU's output order: batch-major, then emitter."""
    runs = []
    batches = -(-int(counts.max(initial=0)) // batch)
    for b in range(batches):
        for e, count in enumerate(counts):
            first = b * batch
            if first < count:
                runs.append((e, first, min(int(count) - first, batch)))
    return runs
