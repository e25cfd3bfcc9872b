"""Turbulent dispersion: a random walk in the flow each particle sees, drawn from the
random texture so that every node draws the same numbers.

The model, per particle at the start of each step of length h (twin of
shaders/include/dispersion.glsl):
  - the eddy diffusivity of Prandtl's mixing length, K = l sigma_w with the turbulent
    velocity sigma_w = l |du/dz| (Prandtl 1925), and l = kappa z / (1 + kappa z / l_inf)
    growing from the ground (Blackadar 1962; z the height above the ground, l_inf the
    scene's `mixing_length`); the shear du/dz from the flow itself by differences over
    SHEAR_STEP. Where the mean shear vanishes, at a wall jet's velocity maximum, the
    turbulence does not: sigma_w is at least TURBULENCE_FLOOR |u| (without it K = 0 there
    walls the dust in below the jet's peak);
  - the particle's share of it, K_p = K lambda / (lambda + sigma_w / l): an eddy turns over
    in about l / sigma_w (1/|du/dz| in the shear), the particle's slip relaxes at its drag
    rate lambda, and a grain slower than the eddies follows them only in part (Tchen's
    ratio T_L / (T_L + tau), Hinze 1975, "Turbulence", sec. 5-6);
  - the flow the particle sees over the step is u(p) + (dK_p/dz) z^ + sqrt(2 K_p / h) xi,
    with xi three independent draws of zero mean and unit variance.
For fine dust (lambda h >> 1) this is the random displacement model
dx = (u + grad K) dt + sqrt(2 K dt) xi (Legg & Raupach 1982; Wilson & Sawford 1996): its
drift keeps a well-mixed tracer well mixed where K changes with height (horizontal
gradients, on the rotor's scale, are left out). A heavy grain gets the same white noise
through its drag: its long-time diffusivity is K_p, and its share keeps saltating sand
near the ground, where l / sigma_w is short. White in frame time: the velocity seen
jumps every frame, and dispersion over times beyond the eddies' turnover is what it gets
right.

The draws: one 32-bit word per particle and frame, at the particle's index in the stream,
the same on every node; word index & 3 of lattice texel index >> 2, moved by the frame's
map (`moved_texel`). Three 10-bit fields j give sqrt(3) ((2j + 1)/1024 - 1), standardised
by the mean and spread of that field over the whole texture (`draw_moments`, float32, once
per seed): a texture of 1M words leaves a mean near 1e-3, and a drift of
sqrt(2 K / h) × 1e-3 is out of balance where K is small, near the ground (without it a
well-mixed tracer lost 8 % of its lowest metre). So xi is uniform, of zero mean and unit
variance over the texture (to float32), summed over frames into Gaussians. Indices repeat words
beyond WORDS_PER_TEXEL × size² particles: the loader holds the capacity below that.
"""

from __future__ import annotations

import numpy as np

from cavesim.core.air import KARMAN
from cavesim.core.fields.snapshot_time import START, FlowSampler
from cavesim.core.random_texture import WORDS_PER_TEXEL, moved_texel

SHEAR_STEP = 0.1  # m: the flow is sampled this far above and below a particle
FIELD_BITS = 10  # bits of a word per draw
FIELD_MASK = (1 << FIELD_BITS) - 1
SQRT3 = np.sqrt(3.0)
# sigma_w >= this × |u|: the turbulence does not vanish where the mean shear does (a wall
# jet's rms vertical velocity stays about a tenth of the local speed through its velocity
# maximum: Launder & Rodi 1983, Annu. Rev. Fluid Mech. 15, 429)
TURBULENCE_FLOOR = 0.1


def raw_draws(words: np.ndarray, dtype=np.float64) -> np.ndarray:
    """sqrt(3) ((2j + 1)/1024 - 1) (..., 3) of the three 10-bit fields j of each word."""
    fields = np.stack([(words >> np.uint32(FIELD_BITS * c)) & FIELD_MASK for c in range(3)],
                      axis=-1).astype(dtype)
    return dtype(SQRT3) * ((2 * fields + 1) * dtype(1 / 1024) - 1)


def draw_moments(random: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(mean, 1 / standard deviation) of each draw over every word of the texture, float32:
    dispersion.glsl's draw_mean and draw_scale."""
    every = raw_draws(random.reshape(-1))
    return every.mean(axis=0).astype(np.float32), (1.0 / every.std(axis=0)).astype(np.float32)


def draws(random: np.ndarray, transform: np.ndarray, count: int,
          moments: tuple[np.ndarray, np.ndarray], dtype=np.float64) -> np.ndarray:
    """xi (count, 3) of the particles at stream indices 0..count-1 in this frame,
    standardised by the texture's `moments` (each operation rounded in `dtype`)."""
    index = np.arange(count, dtype=np.uint64)
    xs, ys = moved_texel((0, 0), index // WORDS_PER_TEXEL, transform, random.shape[0])
    mean, scale = (m.astype(dtype) for m in moments)
    return (raw_draws(random[ys, xs, index % WORDS_PER_TEXEL], dtype) - mean) * scale


def mixing_length(height: np.ndarray, longest: float) -> np.ndarray:
    """l = kappa z / (1 + kappa z / l_inf), 0 at and below the ground."""
    grown = KARMAN * np.maximum(height, 0.0)
    return grown / (1.0 + grown / longest)


def shear_samples(flow: FlowSampler, p: np.ndarray) -> tuple[np.ndarray, ...]:
    """The flow SHEAR_STEP below, at and above points p (N, 3), at the step's start."""
    lift = np.zeros(3, dtype=p.dtype)
    lift[2] = SHEAR_STEP
    return flow(p - lift, START), flow(p, START), flow(p + lift, START)


def particle_diffusivity(below: np.ndarray, here: np.ndarray, above: np.ndarray,
                         height: np.ndarray, drag_rate: np.ndarray, longest: float
                         ) -> tuple[np.ndarray, np.ndarray]:
    """(K_p, dK_p/dz), each (N,), from the flow sampled below, at and above points standing
    `height` (N,) above the ground, for particles whose slip relaxes at `drag_rate` (N,)."""
    shares = []
    for lower, upper, z in ((below, here, height - SHEAR_STEP / 2),
                            (here, above, height + SHEAR_STEP / 2)):
        shear = np.linalg.norm(upper - lower, axis=1) / SHEAR_STEP
        speed = np.linalg.norm(0.5 * (lower + upper), axis=1)
        length = mixing_length(z, longest)
        sigma = np.maximum(length * shear, TURBULENCE_FLOOR * speed)
        # K_p = l sigma lambda / (lambda + sigma / l), written without dividing by l = 0
        relaxed = drag_rate * length
        denominator = relaxed + sigma
        with np.errstate(invalid="ignore", divide="ignore"):  # 0 / 0 in still air at z = 0
            shares.append(np.where(denominator > 0,
                                   length * sigma * relaxed / denominator, 0.0))
    low, high = shares
    return 0.5 * (low + high), (high - low) / SHEAR_STEP


def seen_turbulence(diffusivity: np.ndarray, gradient: np.ndarray, xi: np.ndarray, h: float
                    ) -> np.ndarray:
    """What the particle sees besides u(p) over a step h: drift (dK_p/dz) z^ plus the
    random velocity sqrt(2 K_p / h) xi; (N, 3). Nothing in a step of no time."""
    if h <= 0:
        return np.zeros_like(xi)
    out = np.sqrt(2.0 * diffusivity / h)[:, None] * xi
    out[:, 2] += gradient
    return out


def turbulence(forces, p: np.ndarray, v: np.ndarray, ground: np.ndarray, longest: float,
               xi: np.ndarray, h: float) -> np.ndarray:
    """The turbulence particles at p (N, 3) moving at v see over a step h, over ground of
    height `ground` (N,), with draws xi (N, 3); `forces` gives the flow and drag rate."""
    below, here, above = shear_samples(forces.flow, p)
    rate = forces.drag_rate(here - v)[:, 0]
    diffusivity, gradient = particle_diffusivity(below, here, above, p[:, 2] - ground, rate,
                                                 longest)
    return seen_turbulence(diffusivity, gradient, xi, h)
