"""The dust as a participating medium, measured in pictures against its model
(include/parcel.glsl, render/composite.glsl): Beer-Lambert through a slab of known optical
depth, a ball of dust lit from one side and shadowed by the light map, a slab lit from
behind the viewer, a parcel spreading with age, and the soft edge where a dense cloud meets
the ground.

The slab and the ball are lattices of parcels, dense enough (spacing half a parcel's
radius) that the summed optical depth is smooth; the pictures are read back into radiance
through the tone curve's inverse."""

import dataclasses

import numpy as np
import pytest
from render_helpers import particles_at, small_cave
from scenes import make_scene

from cavesim.gpu.engine import ParticleSystem
from cavesim.gpu.render.medium import billboard_radii, inverse_tone_map, phase
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


def front_picture(ctx, points, ground=False, age=0.0,
                  **settings) -> tuple[np.ndarray, RenderSettings]:
    """The front wall (480 px) of the small CAVE, showing sand parcels at `points`, all of
    age `age` (seconds)."""
    scene = make_scene(drag=False, collision=PLANE if ground else None, capacity=len(points))
    system = ParticleSystem(ctx, scene)
    records = particles_at(points)
    records["age"] = age
    system.write_particles(records)
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


SPREAD = {"eddy_diffusivity": 0.02, "max_radius": 0.6}  # m^2/s, m: a parcel's spread
PIXELS_PER_METRE_AT_8M = 160 * 1.5 / 8  # the front wall: 480 px over 3 m, 1.5 m from the eye
SPREAD_TOLERANCE = 0.05  # relative, on the whole extinction and the half-depth radius


@pytest.mark.parametrize("age", [0.0, 3.0, 60.0])
def test_a_parcel_spreads_as_a_puff_and_keeps_its_whole_extinction(ctx, age):
    """One black parcel 8 m ahead against the sky: it spreads to the radius
    R = min(sqrt(R0^2 + 2 K age), max radius) (Taylor's puff, include/parcel.glsl), seen
    where its optical depth is half its centre's, at r = sqrt(1 - 2^(-2/3)) R; and its
    optical depth summed over the picture is its whole extinction (8/15) pi sigma0 R0^3 at
    every age. Black dust leaves T times the sky: -ln(T) is the optical depth per pixel."""
    r0 = float(billboard_radii(make_scene(drag=False))[0])
    centre = [(0.0, 8.0, 1.5)]
    picture, settings = front_picture(ctx, centre, age=age, dust_albedo=(0.0, 0.0, 0.0),
                                      density_per_particle=2.0, **SPREAD)
    clear, _ = front_picture(ctx, centre, density_per_particle=0.0)
    tau = -np.log(np.clip(luminance_radiance(picture, settings.exposure)
                          / luminance_radiance(clear, settings.exposure), 1e-6, 1.0))
    pixel_area = PIXELS_PER_METRE_AT_8M ** -2
    radius = min(np.sqrt(r0 ** 2 + 2 * SPREAD["eddy_diffusivity"] * age), SPREAD["max_radius"])
    half_depth_radius = np.sqrt((tau >= tau.max() / 2).sum() * pixel_area / np.pi)
    assert abs(half_depth_radius / (np.sqrt(1 - 2 ** (-2 / 3)) * radius) - 1) < \
        SPREAD_TOLERANCE, (half_depth_radius, radius)
    whole = tau.sum() * pixel_area
    assert abs(whole / parcel_extinction(settings, r0) - 1) < SPREAD_TOLERANCE, (
        whole, parcel_extinction(settings, r0))


def sun_octaves(settings: RenderSettings, cosine: float) -> float:
    """The sun term of composite.glsl for dust in full sun: single scattering and the
    multiple-scattering octaves, each with its share of the phase function's anisotropy."""
    def scaled(a: float) -> RenderSettings:
        return dataclasses.replace(settings, forward_scattering=a * settings.forward_scattering,
                                   backward_scattering=a * settings.backward_scattering)
    return sum(2.0 ** -i * float(phase(scaled(2.0 ** -i), cosine)) for i in range(OCTAVES))


def test_dust_with_the_sun_behind_the_viewer_throws_back_its_backward_lobe(ctx):
    """A thin slab of white dust 8 m ahead, the sun straight behind the eye, no skylight
    and a black sky: what it sends back to the eye with the phase function's backward lobe,
    over what it sends without, is the ratio of their sun terms (the slab is thin: its
    shadow dims both alike)."""
    radius = float(billboard_radii(make_scene(drag=False))[0])
    points = lattice((-2.0, 8.0, -0.5), (2.0, 8.0, 3.5), radius / 2)
    light = {"sky": (0.0, 0.0, 0.0), "sky_zenith": (0.0, 0.0, 0.0), "dust_ambient": 0.0,
             "sun_direction": (0.0, -1.0, 0.0), "density_per_particle": 0.02,
             "dust_albedo": (1.0, 1.0, 1.0)}
    seen = {}
    for share in (0.0, RenderSettings().backward_share):
        picture, settings = front_picture(ctx, points, backward_share=share, **light)
        seen[share] = (luminance_radiance(picture[220:260, 220:260], settings.exposure).mean(),
                       sun_octaves(settings, -1.0))
    (plain, plain_model), (backed, backed_model) = seen.values()
    assert backed_model / plain_model > 2 and \
        abs(backed / plain / (backed_model / plain_model) - 1) < 0.1, (
            backed / plain, backed_model / plain_model)


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
        forward_scattering=0.0, backward_share=0.0, density_per_particle=0.04, layer_depth=0.25)
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


CURTAIN_DENSITY = 1.5  # per parcel: the curtain's, whatever the demo's look is tuned to


def steps_where_dust_meets_the_ground(ctx, **settings) -> tuple[float, float]:
    """A dense curtain of black dust (what it hides, not how it is lit) standing on the
    ground 6 to 6.5 m ahead, its parcels' centres from 0.3 m below the ground to 2 m above:
    (along, across), the largest change of the transmittance between neighbouring pixels
    along the line where it meets the ground (row 298: the ground 6.25 m ahead) and across
    it, in the rows about it. Black dust leaves T times the ground's radiance: the ratio
    to the clear picture is T whatever the ground's pattern."""
    points = np.random.default_rng(0).uniform((-3.0, 6.0, -0.3), (3.0, 6.5, 2.0), (1500, 3))
    picture, chosen = front_picture(ctx, points, ground=True, dust_albedo=(0.0, 0.0, 0.0),
                                    density_per_particle=CURTAIN_DENSITY, **settings)
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
