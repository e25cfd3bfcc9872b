"""The shared random texture and the per-frame transform that moves every lookup into it.

Built once on every node from the scene's seed (numpy PCG64), so all nodes hold the same
bytes (determinism rule 2). The clock owner draws one 3x3 integer affine map per frame;
nodes receive it as float32 bits and apply it with integer arithmetic on the GPU, so the
lookup addresses are exact everywhere. Read with texelFetch, never filtered.
"""

from __future__ import annotations

import numpy as np

WORDS_PER_TEXEL = 4  # RGBA32UI
MAX_LINEAR_ENTRY = 15  # small linear part: keeps the map well mixed and the float32 bits exact


def random_words(seed: int, size: int) -> np.ndarray:
    """The texture's content: uint32 words of shape (size, size, 4) from PCG64(seed)."""
    rng = np.random.Generator(np.random.PCG64(seed))
    return rng.integers(0, 2**32, size=(size, size, WORDS_PER_TEXEL), dtype=np.uint32)


def draw_transform(rng: np.random.Generator, size: int) -> np.ndarray:
    """A random affine map of the texture lattice (float32, integer entries, bijective mod size).

    [[a, b, tx], [c, d, ty], [0, 0, 1]] with an odd determinant, which makes it invertible
    modulo a power of two: every frame permutes the lattice instead of folding it.
    """
    while True:
        a, b, c, d = rng.integers(-MAX_LINEAR_ENTRY, MAX_LINEAR_ENTRY + 1, size=4)
        if (a * d - b * c) % 2 == 1:
            break
    tx, ty = rng.integers(0, size, size=2)
    return np.array([[a, b, tx], [c, d, ty], [0, 0, 1]], dtype=np.float32)


def validate_transform(matrix: np.ndarray) -> np.ndarray:
    """Check a received transform and return it as float32 (3, 3); raise ValueError if bad."""
    m = np.asarray(matrix)
    if m.shape != (3, 3):
        raise ValueError(f"random transform must have shape (3, 3), got {m.shape}")
    m = m.astype(np.float32)
    if not np.all(np.isfinite(m)) or not np.array_equal(m, np.round(m)):
        raise ValueError(f"random transform entries must be finite integers, got {m.tolist()}")
    if np.any(np.abs(m) >= 2**24):
        raise ValueError(f"random transform entries must be below 2**24, got {m.tolist()}")
    if not np.array_equal(m[2], [0, 0, 1]):
        raise ValueError(f"random transform's last row must be [0, 0, 1], got {m[2].tolist()}")
    return m


def lookup_coordinates(base: tuple[int, int], serial: np.ndarray, texel: int,
                       matrix: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray]:
    """Texel coordinates of random word-group `texel` of the particles with emission `serial`.

    The same integer arithmetic as `random_lookup` in shaders/particles/emission.glsl:
    lattice index k = 2·serial + texel laid out row by row from the emitter's base, then
    moved by the frame's map, all modulo the texture size.
    """
    k = (np.asarray(serial, dtype=np.uint64) * 2 + texel) & 0xFFFFFFFF
    return moved_texel(base, k, matrix, size)


def moved_texel(base: tuple[int, int], k: np.ndarray, matrix: np.ndarray, size: int
                ) -> tuple[np.ndarray, np.ndarray]:
    """Texel coordinates of lattice index `k` (uint32 values) laid out row by row from
    `base`, then moved by the frame's map, all modulo the texture size (`moved_texel` in
    shaders/include/random.glsl)."""
    k = np.asarray(k, dtype=np.uint64)
    x = (base[0] + k % size) % size
    y = (base[1] + k // size) % size
    m = matrix.astype(np.int64)
    mask = size - 1
    xs = (m[0, 0] * x.astype(np.int64) + m[0, 1] * y.astype(np.int64) + m[0, 2]) & mask
    ys = (m[1, 0] * x.astype(np.int64) + m[1, 1] * y.astype(np.int64) + m[1, 2]) & mask
    return xs, ys


def random_texels(random: np.ndarray, base, serial: np.ndarray, matrix: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """The two texels (N, 4) uint32 of the particles with emission `serial`, as the
    shader's random_lookup fetches them from the texture's words `random`."""
    size = random.shape[0]
    base = tuple(int(b) for b in base)
    texels = []
    for texel in (0, 1):
        xs, ys = lookup_coordinates(base, serial, texel, matrix, size)
        texels.append(random[ys, xs])  # texelFetch(ivec2(x, y)) reads row y, column x
    return texels[0], texels[1]


def unit_float(words: np.ndarray) -> np.ndarray:
    """Map uint32 words to exact float values in [0, 1) with 24 random bits."""
    return (np.asarray(words, dtype=np.uint32) >> 8).astype(np.float64) * 2.0**-24


def emitter_bases(seed: int, count: int, size: int) -> np.ndarray:
    """Each emitter's own base texel (int32, shape (count, 2)), spread apart by the seed."""
    rng = np.random.Generator(np.random.PCG64([seed, 1]))
    return rng.integers(0, size, size=(count, 2), dtype=np.int32)
