"""The dust as a participating medium, measured in pictures against its model
(include/parcel.glsl, render/composite.glsl): Beer-Lambert through a slab of known optical
depth, a ball of dust lit from one side and shadowed by the light map, and the soft edge
where a dense cloud meets the ground.

The slab and the ball are lattices of parcels, dense enough (spacing half a parcel's
radius) that the summed optical depth is smooth; the pictures are read back into radiance
through the tone curve's inverse."""

import numpy as np
import pytest
from render_helpers import particles_at, small_cave
from scenes import make_scene

from cavesim.gpu.engine import ParticleSystem
from cavesim.gpu.render.medium import billboard_radii, inverse_tone_map
from cavesim.gpu.render.wall_renderer import RenderSettings, WallRenderer

EYE = np.array([0.0, 0.0, 1.5])
PLANE = {"kind": "plane", "friction": 0.3, "resilience": 0.4}
SLAB_TOLERANCE = 0.03  # relative, on the transmittance
LIT_TOLERANCE = 0.15  # relative, on the lit side's radiance over the far side's: the light
# map's four layers interpolate the optical depth toward the sun (measured: 10% low)
OCTAVES = 3  # of scattered sunlight, as composite.glsl
MAX_SOFT_STEP = 0.3  # of the transmittance, between neighbouring pixels where dust meets
# the ground


def lattice(low, high, spacing: float) -> np.ndarray:
    axes = [np.arange(a, b + 1e-9, spacing) for a, b in zip(low, high, strict=True)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)


def front_picture(ctx, points, ground=False, **settings) -> tuple[np.ndarray, RenderSettings]:
    """The front wall (480 px) of the small CAVE, showing sand parcels at `points`."""
    scene = make_scene(drag=False, collision=PLANE if ground else None, capacity=len(points))
    system = ParticleSystem(ctx, scene)
    system.write_particles(particles_at(points))
    chosen = RenderSettings(**settings)
    renderer = WallRenderer(ctx, system, small_cave(resolution=(480, 480)).wall("front"),
                            chosen)
    try:
        return renderer.render(EYE, None).astype(float), chosen
    finally:
        renderer.release()
        system.release()


def parcel_extinction(settings: RenderSettings, radius: float) -> float:
    """The optical depth over a new parcel's disc, m^2: (8/15) pi sigma0 R^3."""
    return 8 / 15 * np.pi * settings.opacity * settings.density_per_particle * radius ** 3


def luminance_radiance(picture: np.ndarray, exposure: float) -> np.ndarray:
    return inverse_tone_map(picture / 255.0, exposure).mean(axis=-1)


@pytest.mark.parametrize("layers", [2, 6])
def test_a_slab_passes_exp_minus_its_optical_depth_of_the_background(ctx, layers):
    """Black dust (albedo 0) in a slab across the view 8 m ahead: what is left of the
    sky behind it is exp(-tau), tau the parcels' extinction per unit area of the slab."""
    radius = float(billboard_radii(make_scene(drag=False))[0])
    spacing = radius / 2
    depth = (layers - 1) * spacing
    points = lattice((-2.0, 8.0, -0.5), (2.0, 8.0 + depth, 3.5), spacing)
    picture, settings = front_picture(ctx, points, dust_albedo=(0.0, 0.0, 0.0),
                                      density_per_particle=0.12)
    clear, _ = front_picture(ctx, points, density_per_particle=0.0)  # the sky behind it
    clear = clear[220:260, 220:260]
    tau = parcel_extinction(settings, radius) * layers / spacing ** 2
    centre = picture[220:260, 220:260]
    transmitted = (luminance_radiance(centre, settings.exposure)
                   / luminance_radiance(clear, settings.exposure)).mean()
    assert tau > 0.3 and abs(transmitted / np.exp(-tau) - 1) < SLAB_TOLERANCE, (
        tau, transmitted, np.exp(-tau))


def sunlight_seen(sigma: float, ball: float, x: float) -> float:
    """The sun term of composite.glsl (octaves, isotropic) on a ray through a uniform ball
    of extinction `sigma` at `x` from its centre toward the sun, across the sunlight: the
    dust is uniform over the chord, so the eye sees it at the mean fraction f of it, a point
    sigma (sqrt(ball^2 - y^2) - x) from the sun."""
    half = np.sqrt(ball ** 2 - x ** 2)
    tau = 2 * half * sigma
    y = -half + 2 * half * (1 / tau - 1 / np.expm1(tau))
    tau_sun = sigma * (np.sqrt(ball ** 2 - y ** 2) - x)
    return sum(2.0 ** -i * np.exp(-2.0 ** -i * tau_sun) for i in range(OCTAVES))


def test_a_ball_of_dust_is_brighter_on_its_sunlit_side_by_the_light_between(ctx):
    """A ball of dust 8 m ahead, the sun to its right, no skylight, isotropic scattering,
    before black: a ray at +a (toward the sun) and one at -a cross the same dust (the same
    transmittance and spread along the ray), but the dust they see lies 2 sigma a nearer
    the sun in optical depth: the lit side's radiance over the far side's is the ratio of the
    sunlight reaching those points, as the model has it (`sunlight_seen`)."""
    radius = float(billboard_radii(make_scene(drag=False))[0])
    spacing, ball, centre = radius / 2, 1.5, np.array([0.0, 8.0, 1.5])
    points = lattice(centre - ball, centre + ball, spacing)
    points = points[np.linalg.norm(points - centre, axis=1) <= ball]
    picture, settings = front_picture(
        ctx, points, sky=(0.0, 0.0, 0.0), sun_direction=(1.0, 0.0, 0.0), dust_ambient=0.0,
        forward_scattering=0.0, density_per_particle=0.04, layer_depth=0.25)
    sigma = parcel_extinction(settings, radius) / spacing ** 3
    # the pixel column at x = +-a on the ball's plane, 8 m ahead, from the eye 1.5 m behind
    # a 3 m wall of 480 px: 160 px per metre on the wall, 1.5 / 8 of that at the ball
    a = 0.6
    offset = round(a * 160 * 1.5 / 8)
    rows = slice(235, 245)
    radiance = luminance_radiance(picture, settings.exposure)
    lit = radiance[rows, 240 + offset - 2:240 + offset + 3].mean()
    far = radiance[rows, 240 - offset - 2:240 - offset + 3].mean()
    expected = sunlight_seen(sigma, ball, a) / sunlight_seen(sigma, ball, -a)
    assert expected > 1.5 and abs(lit / far / expected - 1) < LIT_TOLERANCE, (
        lit / far, expected)


def steps_where_dust_meets_the_ground(ctx, **settings) -> tuple[float, float]:
    """A dense curtain of black dust (what it hides, not how it is lit) standing on the
    ground 6 to 6.5 m ahead, its parcels' centres from 0.3 m below the ground to 2 m above:
    (along, across), the largest change of the transmittance between neighbouring pixels
    along the line where it meets the ground (row 298: the ground 6.25 m ahead) and across
    it, in the rows about it. Black dust leaves T times the ground's radiance: the ratio
    to the clear picture is T whatever the ground's pattern."""
    points = np.random.default_rng(0).uniform((-3.0, 6.0, -0.3), (3.0, 6.5, 2.0), (1500, 3))
    picture, chosen = front_picture(ctx, points, ground=True, dust_albedo=(0.0, 0.0, 0.0),
                                    **settings)
    clear, _ = front_picture(ctx, np.array([[0.0, -50.0, 1.0]]), ground=True)
    rows = slice(290, 306), slice(60, 420)
    transmitted = (luminance_radiance(picture[rows], chosen.exposure)
                   / luminance_radiance(clear[rows], chosen.exposure))
    return (float(np.abs(np.diff(transmitted, axis=1)).max()),
            float(np.abs(np.diff(transmitted, axis=0)).max()))


def test_dust_fades_into_the_ground_without_a_hard_edge(ctx):
    """The billboards that the ground cuts fade over `soft_distance` along the ray: no
    scalloped edge along the line where the cloud stands on the ground (measured: along 0.14,
    across 0.41 of the transmittance; cut hard, 0.67 and 0.88)."""
    along, across = steps_where_dust_meets_the_ground(ctx)
    hard_along, hard_across = steps_where_dust_meets_the_ground(ctx, soft_distance=1e-4)
    assert along < MAX_SOFT_STEP < hard_along, (along, hard_along)
    assert across < hard_across
