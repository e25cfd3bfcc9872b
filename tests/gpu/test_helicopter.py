"""The brownout demo's physics: downwash, ground effect, saltation, flight, GPU vs twin."""

import copy

import numpy as np
import pytest
from scenes import SAND

from cavesim.core.drivers.helicopter import HelicopterDriver
from cavesim.core.errors import SceneError
from cavesim.core.helicopter.downwash import downwash, friction_velocity, jet_peak
from cavesim.core.helicopter.flight import Flight
from cavesim.core.helicopter.rotor import ground_effect, induced_velocity, saltation_factor
from cavesim.core.random_texture import draw_transform
from cavesim.core.scene import load_scene, parse_scene
from cavesim.core.scene_frame import NOTHING_MOVES
from cavesim.core.twin.system import TwinSystem
from cavesim.gpu.engine import FrameInput, ParticleSystem

BROWNOUT = load_scene("config/scenes/brownout.toml")
HELI = BROWNOUT.helicopter
R = HELI.rotor_radius


def flow(points, hub=(0.0, 0.0, 12.0), v_i=10.0):
    return downwash(np.atleast_2d(points), hub, v_i, R, 0.0)


def test_flow_goes_down_through_the_disk_and_out_along_the_ground():
    below = flow([[0.5, 0.3, 9.0], [3.0, 0.0, 6.0], [0.0, 0.0, 12.0]])
    assert (below[:, 2] < 0).all(), "down through and under the disk"
    at_disk = flow([[0.0, 0.0, 60.0]], hub=(0.0, 0.0, 60.0))[0, 2]  # far above any ground
    assert at_disk == pytest.approx(-10.0, abs=1e-9), "v_i at the disk's centre"
    far_below = flow([[0.0, 0.0, 5.0]])[0, 2]
    assert far_below < -10.0, "the wake speeds up below the disk (toward 2 v_i)"
    for angle in np.linspace(0, 2 * np.pi, 7):
        r = 2 * R
        ground = flow([[r * np.cos(angle), r * np.sin(angle), 0.1 * R + 0.05 * R]])[0]
        radial = ground[0] * np.cos(angle) + ground[1] * np.sin(angle)
        assert radial > 1.0, "outward along the ground at two radii"
    assert np.isfinite(flow([[0.0, 0.0, 0.0], [0.0, 0.0, 12.0], [50, 50, 40]])).all()


def test_wall_jet_decays_with_distance():
    speeds = jet_peak(np.array([1.5, 3.0, 6.0]) * R, 12.0, 10.0, R)[0]
    assert speeds[0] > speeds[1] > speeds[2] > 0


def test_magnitude_scales_with_rotor_speed_and_ground_effect():
    v_hover = induced_velocity(HELI, 1.0, 100.0)
    assert induced_velocity(HELI, 1.2, 100.0) == pytest.approx(1.2 * v_hover, rel=1e-9)
    assert v_hover == pytest.approx(np.sqrt(HELI.weight / (2 * HELI.air_density
                                                           * HELI.disk_area)), rel=1e-3)
    heights = [4 * R, 2 * R, R, 0.5 * R]
    effects = [ground_effect(h, R) for h in heights]
    assert effects == sorted(effects, reverse=True) and effects[-1] == pytest.approx(0.75)
    assert induced_velocity(HELI, 1.0, 0.6 * R) < induced_velocity(HELI, 1.0, 3 * R)
    strong, weak = flow([[2 * R, 0, 1.0]], v_i=12.0)[0], flow([[2 * R, 0, 1.0]], v_i=6.0)[0]
    assert np.linalg.norm(strong) == pytest.approx(2 * np.linalg.norm(weak), rel=1e-9)


def test_emission_grows_as_the_helicopter_comes_down():
    """The wall jet's momentum is the thrust's wherever the rotor is (Poreh et al. 1967), so
    dust rises from well up; it grows as the wake reaches the ground less spread."""
    factors = []
    for height in (100.0, 40.0, 15.0, 6.0, 3.0):
        v_i = induced_velocity(HELI, 1.0, height)
        factors.append(float(saltation_factor(HELI, friction_velocity(HELI, 1.3 * R,
                                                                      height, v_i))))
    assert all(a < b for a, b in zip(factors, factors[1:], strict=False))
    assert factors[-1] > 3 * factors[0] > 0
    far_up = induced_velocity(HELI, 1.0, 300.0)
    assert saltation_factor(HELI, friction_velocity(HELI, 1.3 * R, 300.0, far_up)) == 0.0
    assert saltation_factor(HELI, HELI.threshold_friction_velocity * 0.99) == 0.0


def test_sand_flux_is_linear_in_the_shear_stress():
    """Q / Q_t = (u*/u*_t)² - 1: linear in rho u*² above the threshold stress (Martin & Kok
    2017), where the old (u*/u*_t)³ - 1 grew faster."""
    u_t = HELI.threshold_friction_velocity
    stress = np.linspace(1.0, 6.0, 11) * u_t**2  # in units of rho
    factors = saltation_factor(HELI, np.sqrt(stress))
    np.testing.assert_allclose(np.diff(factors), np.diff(stress)[0] / u_t**2, rtol=1e-12)
    assert saltation_factor(HELI, np.sqrt(2.0) * u_t) == pytest.approx(1.0)
    assert saltation_factor(HELI, 0.0) == 0.0


def test_dust_rises_only_with_the_sand_that_blasts_it():
    """Sandblasting: a dust emitter at a sand emitter's distance gets its factor, and none
    where the sand does not saltate (no threshold of its own)."""
    data = load_scene_dict()
    sand = next(e for e in data["emitter"] if e["particle_class"] == "sand")
    dust = copy.deepcopy(next(e for e in data["emitter"] if e["particle_class"] == "dust"))
    dust.update(name="dust_with_sand", position=sand["position"])
    data["emitter"] = [sand, dust]
    scene = parse_scene(data, name="blast")
    for frame in fly(scene):
        sand_factor, dust_factor = frame.rotor.emission_factors
        assert dust_factor == sand_factor


@pytest.mark.slow
def test_sand_hops_stay_low_and_the_wash_lifts_the_dust():
    """Hovering over the ground (frames 600-720), 99% of the sand stays within 0.3 m while
    the turbulence lifts a tenth of the dust above 1.2 m, out of the wall jet's lowest
    metre (float64 twin, rates cut to a quarter). Slow (12 s of flight, tens of thousands
    of particles): the only test of where the demo's sand and dust end up."""
    data = load_scene_dict()
    data["simulation"]["capacity"] = 75000
    for e in data["emitter"]:
        e["rate"] /= 4
    scene = parse_scene(data, name="hover")
    twin = TwinSystem(scene)
    rng = np.random.default_rng(5)
    sand_heights = []
    for k, scene_frame in enumerate(fly(scene, seconds=12.0), start=1):
        twin.step(FrameInput(1 / 60, draw_transform(rng, scene.random_texture_size)),
                  scene_frame)
        if k >= 600 and k % 30 == 0:
            q = twin.particles
            sand_heights.append(q.pos[q.class_id == 0, 2])
    heights = np.concatenate(sand_heights)
    assert len(heights) > 5000 and np.percentile(heights, 99) < 0.3
    dust = twin.particles.pos[twin.particles.class_id == 1, 2]
    assert np.percentile(dust, 90) > 1.2


def fly(scene, seconds=15.0, dt=1 / 60):
    """The frames a master makes from the scene's timeline, as a node decodes them."""
    driver = HelicopterDriver(scene)
    return [driver.decode(driver.encode(driver.advance(k * dt, dt, None).frame))
            for k in range(1, round(seconds / dt) + 1)]


def test_scripted_timeline_is_deterministic_and_lands():
    first, second = fly(BROWNOUT), fly(BROWNOUT)
    assert first == second
    altitudes = [frame.helicopter.position[2] for frame in first]  # the skids; ground at 0
    assert altitudes[0] > 20 and min(altitudes) == pytest.approx(0.0, abs=0.5), "lands"
    assert altitudes[-1] > 5, "lifts off again"
    total_emission = [sum(frame.rotor.emission_factors) for frame in first]
    assert max(total_emission) > 2 * total_emission[0] > 0, "dust from up high, most down low"


def small_brownout(capacity=6000):
    data = load_scene_dict()
    data["simulation"]["capacity"] = capacity
    data["simulation"]["random_texture_size"] = 64
    data["emitter"] = data["emitter"][:2] + data["emitter"][8:10]
    for e in data["emitter"]:
        e["rate"] = e["rate"] / 4
    return parse_scene(data, name="small")


def load_scene_dict():
    import tomllib

    with open("config/scenes/brownout.toml", "rb") as f:
        return copy.deepcopy(tomllib.load(f))


def test_gpu_rotor_flow_and_following_emitters_match_the_twin(ctx):
    scene = small_brownout()
    gpu, twin = ParticleSystem(ctx, scene), TwinSystem(scene)
    rng = np.random.default_rng(2)
    frames = fly(scene, seconds=12.0)[480:600]  # descending into hover: emission under way
    for scene_frame in frames:
        frame = FrameInput(1 / 60, draw_transform(rng, 64))
        gpu.step(frame, scene_frame)
        twin.step(frame, scene_frame)
        assert gpu.live_count == twin.live_count
    assert gpu.live_count > 500
    records = gpu.read_particles()
    np.testing.assert_array_equal(gpu.read_emitters(), twin.emitters)
    np.testing.assert_array_equal(records["age"], twin.particles.age)
    np.testing.assert_allclose(records["pos"], twin.particles.pos, rtol=1e-4, atol=2e-3)
    assert (records["pos"][:, 2] >= 0).all()
    hub = np.array(frames[-1].rotor.hub)
    spread = np.linalg.norm(records["pos"][:, :2] - hub[:2], axis=1)
    assert spread.mean() > R, "the dust is blown outward from under the rotor"


def test_a_helicopter_step_needs_its_rotor_frame(ctx):
    system = ParticleSystem(ctx, small_brownout())
    with pytest.raises(ValueError, match="steps with a rotor frame of 4 emission factors"):
        system.step(FrameInput(1 / 60, np.eye(3)), NOTHING_MOVES)


@pytest.mark.parametrize(("change", "key"), [
    (lambda d: d.pop("helicopter"), "helicopter"),
    (lambda d: d["field"].update(resolution=[4, 4, 4]), "field.resolution"),
    (lambda d: d["field"].update(interpolation="bspline"), "field.interpolation"),
    (lambda d: d["helicopter"]["timeline"][1].update(t=0.0), "helicopter.timeline[1].t"),
    (lambda d: d["emitter"][0].update(follow_helicopter="yes"), "emitter[0].follow_helicopter"),
    (lambda d: d["helicopter"].update(rotor_radius=-1.0), "helicopter.rotor_radius"),
])
def test_bad_helicopter_scenes_are_rejected(change, key):
    data = load_scene_dict()
    change(data)
    with pytest.raises(SceneError, match=key.replace("[", r"\[").replace("]", r"\]")):
        parse_scene(data, name="bad")


def test_sand_class_is_the_test_scenes_sand():
    assert SAND["density"] == BROWNOUT.particle_classes[0].density


def test_wand_tilt_sets_rotor_speed_and_heading_turns_the_nose():
    import math

    from cavesim.core.helicopter.flight import heading_of, pitch_quaternion, tilt_of

    assert tilt_of(pitch_quaternion(20.0)) == pytest.approx(20.0)
    quarter = (0.0, 0.0, math.sin(math.pi / 4), math.cos(math.pi / 4))  # 90 deg about z
    assert heading_of(quarter) == pytest.approx(math.pi / 2)
    flight = Flight(BROWNOUT)
    level = flight.advance(1 / 60, (0, 0, 1), 0.0)
    assert level.rotor.rotor_speed == 1.0 and level.helicopter.yaw == pytest.approx(-math.pi / 2)
    faster = flight.advance(1 / 60, (0, 0, 1), 30.0, math.pi / 2)
    assert faster.rotor.rotor_speed == pytest.approx(1.25)
    assert faster.helicopter.yaw == pytest.approx(0.0)
    assert faster.rotor.induced_velocity > level.rotor.induced_velocity


def test_a_turned_wand_keeps_its_tilt_and_its_heading():
    import math

    from cavesim.core.helicopter.flight import heading_of, tilt_of

    for heading, tilt in ((90.0, 20.0), (-135.0, -10.0), (10.0, 60.0)):
        h, t = math.radians(heading) / 2, math.radians(tilt) / 2
        yaw = np.array([0.0, 0.0, math.sin(h), math.cos(h)])
        # the wand turned by `heading` about z, then pitched by `tilt` about its own x
        q = np.array([yaw[3] * math.sin(t), yaw[2] * math.sin(t), yaw[2] * math.cos(t),
                      yaw[3] * math.cos(t)])
        assert tilt_of(q) == pytest.approx(tilt)
        assert math.degrees(heading_of(q)) == pytest.approx(heading)
