"""A solid-body vortex about the z axis, u = Omega z x p, and its closed-form paths (a
rotation of the start by Omega t): the passive tracers' flow, in `cavesim accuracy`'s tracer
case and in the tracer tests, sampled on a grid or as the function itself."""

from __future__ import annotations

import numpy as np

from cavesim.core.fields.grid import FieldGrid
from cavesim.core.fields.snapshot_time import START

OMEGA = 1.0  # rad/s
BOX = ((-1.0, -1.0, 0.0), (1.0, 1.0, 1.0))  # m: holds the disk below at every angle


def solid_body(p: np.ndarray, stage: int = START) -> np.ndarray:
    """u(p) for points (N, 3); steady, so every stage of a step alike."""
    return OMEGA * np.stack([-p[:, 1], p[:, 0], np.zeros(len(p))], axis=1)


def centripetal(p: np.ndarray) -> np.ndarray:
    """du/dt along a path through p: the acceleration of the rotation, -Omega² (x, y, 0)."""
    return -OMEGA**2 * np.stack([p[:, 0], p[:, 1], np.zeros(len(p))], axis=1)


def rotated(p: np.ndarray, t: float) -> np.ndarray:
    """Where a tracer at p is after t seconds."""
    c, s = np.cos(OMEGA * t), np.sin(OMEGA * t)
    return np.stack([c * p[:, 0] - s * p[:, 1], s * p[:, 0] + c * p[:, 1], p[:, 2]], axis=1)


def disk(count: int, radius: float = 0.8, height: float = 0.5, seed: int = 3) -> np.ndarray:
    """`count` points spread evenly over a horizontal disk about the axis."""
    rng = np.random.default_rng(seed)
    r = radius * np.sqrt(rng.uniform(size=count))
    phi = rng.uniform(0, 2 * np.pi, size=count)
    return np.stack([r * np.cos(phi), r * np.sin(phi), np.full(count, height)], axis=1)


def solid_body_grid(nodes: int) -> FieldGrid:
    """The vortex at `nodes`³ nodes spanning BOX, float32. The flow is linear, so trilinear
    interpolation of the grid errs only by the float32 rounding of its node values."""
    axes = [np.linspace(lo, hi, nodes) for lo, hi in zip(*BOX, strict=True)]
    z, y, x = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    points = np.stack([x, y, z], axis=-1).reshape(-1, 3)
    velocity = solid_body(points).reshape(nodes, nodes, nodes, 3).astype(np.float32)
    return FieldGrid(velocity, *BOX)
