"""The rotor downwash's physics: a stream function's flow (divergence-free, no kinks), the
ground effect at equal thrust, and the outwash against published radial wall-jet data."""

import math

import numpy as np
import pytest

from cavesim.core.helicopter.downwash import (
    PROFILE_PEAK,
    PROFILE_PEAK_HEIGHT,
    _profile,
    downwash,
    jet_peak,
    stream_function,
)
from cavesim.core.helicopter.outwash import (
    outwash_profile,
    poreh_half_width,
    poreh_peak_speed,
    verhoff_profile,
)
from cavesim.core.helicopter.rotor import ground_effect, induced_velocity
from cavesim.core.scene import load_scene

HELI = load_scene("config/scenes/brownout.toml").helicopter
R = HELI.rotor_radius
V_HOVER = math.sqrt(HELI.weight / (2 * HELI.air_density * HELI.disk_area))  # v_h, out of GE
HUB_HEIGHTS = (0.41 * R, R, 2 * R)  # on its skids (the demo's 3 m), one and two radii up


def hub_at(height):
    return np.array([1.5, -2.0, 0.2 + height])  # over a ground plane at z = 0.2


def flow(points, height):
    return downwash(points, hub_at(height), induced_velocity(HELI, 1.0, height), R, 0.2)


def points_around(height, count=4000, seed=3):
    """Points in the wake, the turning region, the wall jet and the inflow above the disk."""
    rng = np.random.default_rng(seed)
    xy = rng.uniform(-5 * R, 5 * R, (count, 2)) + hub_at(height)[:2]
    z = 0.2 + R * rng.uniform(0.001, 1.0, count) ** 2 * (height / R + 2.0)
    return np.column_stack([xy, z])


def gradient(height, points, step=1e-5):
    """du_i/dx_j (N, 3, 3) by central differences of the analytic velocity."""
    grad = np.empty((len(points), 3, 3))
    for j in range(3):
        shift = np.zeros(3)
        shift[j] = step
        grad[:, :, j] = (flow(points + shift, height) - flow(points - shift, height)) / (2 * step)
    return grad


@pytest.mark.parametrize("height", HUB_HEIGHTS)
def test_divergence_is_zero_to_rounding_on_a_grid(height):
    """The old model had |div u| of 0.3-0.6 1/s in the wake, wall jet and upwash ring; here
    central differences leave only their own error, which falls as the step squared."""
    points = points_around(height)
    divergence = {}
    for step in (1e-4, 1e-5):
        grad = gradient(height, points, step)
        divergence[step] = np.abs(np.trace(grad, axis1=1, axis2=2)).max()
    assert divergence[1e-5] < 1e-6, "1/s"
    assert divergence[1e-4] > 50 * divergence[1e-5], "what is left is the differences' error"
    stretching = np.abs(np.diagonal(grad, axis1=1, axis2=2)).sum(axis=1)
    assert stretching.max() > 10.0, "1/s: the grid reaches the flow's strong gradients"


@pytest.mark.parametrize("height", HUB_HEIGHTS)
def test_velocity_is_the_curl_of_the_stream_function(height):
    points = points_around(height, 1000)
    hub, v_i, step = hub_at(height), induced_velocity(HELI, 1.0, height), 1e-5
    offset = points[:, :2] - hub[:2]
    r = np.hypot(offset[:, 0], offset[:, 1])
    radial = np.column_stack([offset / r[:, None], np.zeros(len(r))])
    vertical = np.array([0.0, 0.0, step])

    def psi(p):
        return stream_function(p, hub, v_i, R, 0.2)

    d_psi_dr = (psi(points + step * radial) - psi(points - step * radial)) / (2 * step)
    d_psi_dz = (psi(points + vertical) - psi(points - vertical)) / (2 * step)
    u = flow(points, height)
    np.testing.assert_allclose(np.einsum("ij,ij->i", u, radial), -d_psi_dz / r, atol=1e-5)
    np.testing.assert_allclose(u[:, 2], d_psi_dr / r, atol=1e-5)


# Where the old model had kinks (r = R, 1.5 R, 3 R) and where the flow's pieces meet: the
# axis, the disk plane, the ground (the flow continues below it by reflection).
SEAMS = {
    "rotor rim": ((R, 0.0, 0.5 * R), (1.0, 0.0, 0.0)),
    "old upwash start": ((1.5 * R, 0.0, 0.3 * R), (1.0, 0.0, 0.0)),
    "old upwash end": ((3 * R, 0.0, 0.4 * R), (1.0, 0.0, 0.0)),
    "axis": ((0.0, 0.0, 0.3 * R), (0.6, 0.8, 0.0)),
    "disk plane": ((0.5 * R, 0.0, R), (0.0, 0.0, 1.0)),
    "ground": ((2 * R, 0.0, 0.0), (0.0, 0.0, 1.0)),
}


@pytest.mark.parametrize("seam", SEAMS)
def test_the_velocity_gradient_is_continuous_everywhere(seam):
    """C1: the jump of du/dx across a point shrinks with the distance across it."""
    (x, y, z), normal = SEAMS[seam]
    point = hub_at(R) * [1, 1, 0] + [x, y, 0.2 + z]
    jumps = []
    for distance in (1e-3, 1e-4):
        across = point + distance * np.array([normal, -np.asarray(normal)])
        g = gradient(R, across, step=1e-7)
        jumps.append(np.abs(g[0] - g[1]).max())
    assert jumps[1] < 0.2 * jumps[0] + 1e-4, f"{seam}: {jumps} (a kink keeps its jump)"


def test_no_flow_through_or_along_the_ground():
    xy = points_around(R)[:, :2]
    on_ground = flow(np.column_stack([xy, np.full(len(xy), 0.2)]), R)
    np.testing.assert_allclose(on_ground, 0.0, atol=1e-12)


def test_hover_thrust_is_the_weight_and_the_ground_lowers_v_i():
    """Cheeseman & Bennett: at equal thrust v_i falls by 1 - (R/4z)², held below z = R/2."""
    assert ground_effect(100 * R, R) == pytest.approx(1.0, abs=1e-4)
    assert ground_effect(R, R) == pytest.approx(15 / 16)
    assert ground_effect(0.5 * R, R) == ground_effect(0.3 * R, R) == pytest.approx(0.75)
    for height in (0.41 * R, R, 2 * R, 10 * R):
        v_i = induced_velocity(HELI, 1.0, height)
        out_of_ground_effect = v_i / ground_effect(height, R)
        thrust = 2 * HELI.air_density * HELI.disk_area * out_of_ground_effect**2
        assert thrust == pytest.approx(HELI.weight, rel=1e-12), "T = W in hover"
    on_skids = induced_velocity(HELI, 1.0, HELI.hub_height)
    assert on_skids == pytest.approx(0.75 * V_HOVER, rel=1e-9), "the demo: 0.75 v_h, not 1.155"


def test_v_i_at_the_disk_centre_far_from_the_ground():
    hub = np.array([0.0, 0.0, 80 * R])
    u = downwash(np.array([hub]), hub, 10.0, R, 0.0)
    np.testing.assert_allclose(u, [[0.0, 0.0, -10.0]], atol=1e-9)


def test_the_profile_constants_are_its_peak():
    eta = np.linspace(0.0, 1.0, 200_001)
    f = _profile(eta)[1] * (PROFILE_PEAK / _profile(PROFILE_PEAK_HEIGHT)[1])
    assert eta[np.argmax(f)] == pytest.approx(PROFILE_PEAK_HEIGHT, abs=1e-4)
    assert f.max() == pytest.approx(PROFILE_PEAK, rel=1e-7)


# Validation. No digitised rotor outwash measurements were at hand, so the references are
# correlations fitted to measured radial wall jets (cavesim/core/helicopter/outwash.py).

FAR = np.array([5.0, 6.0, 8.0, 10.0])  # r/R: the self-similar wall jet


@pytest.mark.parametrize("height", HUB_HEIGHTS)
def test_far_outwash_follows_poreh_tsuei_cermak(height):
    """Peak speed within 10% and half-width within 15% of Poreh et al. (1967)."""
    v_i = induced_velocity(HELI, 1.0, height)
    for r in FAR * R:
        measured = outwash_profile(r, height, v_i, R)
        speed = poreh_peak_speed(V_HOVER, R, height, r)
        assert measured.peak_speed == pytest.approx(speed, rel=0.10), f"u_max at r = {r / R} R"
        width = poreh_half_width(R, height, r)
        assert measured.half_width == pytest.approx(width, rel=0.15), f"delta at r = {r / R} R"


@pytest.mark.parametrize("height", HUB_HEIGHTS)
def test_vertical_profile_follows_verhoff(height):
    """u / u_max against z / delta within 0.05 of Verhoff's profile for 0.1 <= eta <= 2."""
    v_i = induced_velocity(HELI, 1.0, height)
    for r in (2 * R, 3 * R, *FAR * R):
        p = outwash_profile(r, height, v_i, R)
        eta = p.z / p.half_width
        inside = (eta >= 0.1) & (eta <= 2.0)
        error = np.abs(p.u[inside] / p.peak_speed - verhoff_profile(eta[inside]))
        assert error.max() < 0.05, f"r = {r / R} R: {error.max():.3f}"


def test_outwash_stays_below_the_bernoulli_speed():
    """Air that went through the disk has at most the total head p + T/A: no outwash is
    faster than sqrt(2 T / rho A) = 2 v_h."""
    for height in HUB_HEIGHTS:
        v_i = induced_velocity(HELI, 1.0, height)
        speeds = [outwash_profile(r, height, v_i, R).peak_speed
                  for r in np.linspace(0.2, 10.0, 50) * R]
        assert max(speeds) < 2 * V_HOVER and max(speeds) > 1.2 * V_HOVER


def test_far_outwash_depends_on_the_weight_not_the_disk_loading():
    """O'Bryan (1961, NASA TN D-977): away from the rotor the outwash's dynamic pressure is
    set by the gross weight alone."""
    r, height = 60.0, 6.0
    speeds = []
    for radius in (R, 0.7 * R):
        v_hover = math.sqrt(HELI.weight / (2 * HELI.air_density * math.pi * radius**2))
        v_i = v_hover * ground_effect(height, radius)
        speeds.append(outwash_profile(r, height, v_i, radius).peak_speed)
    assert speeds[0] == pytest.approx(speeds[1], rel=0.05)


def test_jet_peak_is_where_the_profile_peaks():
    v_i = induced_velocity(HELI, 1.0, R)
    for r in (1.3 * R, 2 * R, 4 * R):
        speed, z = jet_peak(r, R, v_i, R)
        measured = outwash_profile(r, R, v_i, R)
        assert speed == pytest.approx(measured.peak_speed, rel=0.02)
        assert z == pytest.approx(measured.peak_height, rel=0.1)


def test_the_validation_figure_is_written(tmp_path):
    from cavesim.tools.reports.outwash_figure import plot_outwash

    path = tmp_path / "outwash.png"
    plot_outwash(path)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and path.stat().st_size > 50_000


def test_the_shaders_constants_are_the_float64_models():
    """rotor.glsl's literals (their bits in cavesim/core/portable/constants.py, which
    tests/gpu/test_portable_physics.py holds to the shader) round the float64 model's values."""
    import cavesim.core.helicopter.downwash as model
    from cavesim.core.portable import constants, rotor

    values = {
        "WAKE_SPREADING": model.WAKE_SPREADING,
        "WALL_JET_GROWTH": model.WALL_JET_GROWTH,
        "WALL_JET_WIDTH_SQ": model.WALL_JET_WIDTH**2,
        "FOUR_PROFILE_INTEGRAL": 4 * model.PROFILE_INTEGRAL,
        "PROFILE_DECAY": model.PROFILE_DECAY,
        "PROFILE_SHAPE": model.PROFILE_SHAPE,
        "PROFILE_INNER": model.PROFILE_INNER,
        "PROFILE_FLUX": model.PROFILE_FLUX,
        "ONE_FIFTH": model.FLUX_GROWTH_EXPONENT / 4,  # also H^0.2 of (0.098 H^0.1)²
        "TWO_FIFTHS": model.FLUX_GROWTH_EXPONENT / 2,
        "WIDTH_POWER": 2 * model.WALL_JET_WIDTH_EXPONENT,
        "HALF_WIDTH_POWER": model.WALL_JET_WIDTH_EXPONENT / 2,
    }
    for name, value in values.items():
        assert getattr(constants, name) == np.float32(value), name
    assert rotor.PROFILE_RISE == model.PROFILE_RISE
    assert rotor.GROWTH_POWER == 1 / model.FLUX_GROWTH_EXPONENT
