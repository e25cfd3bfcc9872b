"""The dust as a participating medium, on the CPU side: how large and how dense a drawn
particle is (the uniforms of include/parcel.glsl), and the tone curve of the composite,
mirrored so that reports can tell which display colours lit dust takes."""

from __future__ import annotations

from typing import Protocol

import moderngl
import numpy as np

from cavesim.core.scene.model import Scene


class MediumSettings(Protocol):
    """What of `wall_renderer.RenderSettings` the medium reads (that module draws with it)."""

    dust_albedo: tuple[float, float, float]
    dust_ambient: float
    opacity: float
    density_per_particle: float
    min_radius_pixels: float
    sun_radiance: float
    exposure: float
    eddy_diffusivity: float
    max_radius: float
    fade_time: float
    light_map_size: int
    layer_depth: float
    forward_scattering: float
    backward_scattering: float
    backward_share: float


def billboard_radii(scene: Scene) -> np.ndarray:
    """Drawn radius per particle class: each simulated particle stands for a parcel of
    grains, larger for coarser grains (which travel in denser bunches)."""
    diameters = np.array([c.diameter for c in scene.particle_classes] or [1e-4])
    return np.clip(0.2 * (diameters / 150e-6) ** 0.25, 0.06, 0.35).astype(np.float32)


def set_parcel_uniforms(program: moderngl.Program, scene: Scene,
                        settings: MediumSettings) -> None:
    """The uniforms of include/parcel.glsl: the same medium in every program that draws it
    (a program that needs only the parcels' sizes has the others compiled away)."""
    program["billboard_radius"].write(billboard_radii(scene).tobytes())
    values = {"peak_extinction": settings.opacity * settings.density_per_particle,
              "eddy_diffusivity": settings.eddy_diffusivity, "max_radius": settings.max_radius,
              "fade_time": settings.fade_time}
    for name, value in values.items():
        if name in program:
            program[name].value = value


LUMA = np.array([0.2126, 0.7152, 0.0722])  # Rec. 709


def tone_map(radiance: np.ndarray, exposure: float) -> np.ndarray:
    """Reinhard's curve on the exposed radiance's luminance, keeping its hue, as
    composite.glsl: (..., 3) radiance to display values."""
    x = exposure * np.asarray(radiance, dtype=float)
    return x / (1.0 + x @ LUMA)[..., None]


def inverse_tone_map(display: np.ndarray, exposure: float) -> np.ndarray:
    """The radiance that `tone_map` shows as `display` (values in [0, 1))."""
    y = np.asarray(display, dtype=float)
    return y / (1.0 - y @ LUMA)[..., None] / exposure


def phase(settings: MediumSettings, cosine: np.ndarray) -> np.ndarray:
    """The dust's phase function relative to isotropic scattering, as composite.glsl: two
    Henyey-Greenstein lobes at the cosine of the angle between the sunlight and the view."""
    def henyey_greenstein(g: float) -> np.ndarray:
        d = 1.0 + g * g - 2.0 * g * np.asarray(cosine, float)
        return (1.0 - g * g) / (d * np.sqrt(d))

    share = settings.backward_share
    return ((1.0 - share) * henyey_greenstein(settings.forward_scattering)
            + share * henyey_greenstein(settings.backward_scattering))


def lit_dust_colours(settings: MediumSettings, count: int = 65) -> np.ndarray:
    """(count, 3) display colours (0-255) of opaque dust: lit by the whole skylight and by
    sunlight from none (in full shade) to the most its phase function scatters toward an
    eye (looking into the sun): what a cloud dense enough to hide the world shows."""
    most = float(phase(settings, 1.0))
    sun = np.linspace(0.0, most, count)[:, None]
    radiance = np.asarray(settings.dust_albedo) * settings.sun_radiance * (
        sun + settings.dust_ambient)
    return 255.0 * tone_map(radiance, settings.exposure)
