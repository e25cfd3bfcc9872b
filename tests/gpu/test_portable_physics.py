"""Portable arithmetic: the GPU and its float32 numpy twin give the same bits, every frame.

With `[simulation] arithmetic = "portable"` every float operation whose result enters the
particle or emitter stream goes through arithmetic.glsl's correctly rounded functions, and
cavesim/core/portable/ repeats each shader function operation by operation in numpy
float32 (which rounds every operation correctly and never fuses). So the twin's streams,
hashed by the checksum's numpy reference, must have the GPU's checksum every frame on both
engine paths: any other bits on another GPU are that GPU's error.
"""

from __future__ import annotations

import dataclasses
import re
import subprocess
import tomllib
from pathlib import Path

import numpy as np
import pytest
from scenes import FOUNTAIN, SMOKE, particle_cloud, scene_dict

from cavesim.core.digest.shape import StateChecksum
from cavesim.core.digest.twin import reference_checksum
from cavesim.core.drivers import driver_for
from cavesim.core.fields.heights import HeightGrid, save_heightfield
from cavesim.core.frame import FrameInput
from cavesim.core.portable import constants
from cavesim.core.random_texture import draw_transform
from cavesim.core.record_diff import differences
from cavesim.core.scene import Arithmetic, Integrator, Scene, parse_scene
from cavesim.core.scene.model import ENGINE_PATHS
from cavesim.core.substeps import UNITS, SubstepCounts
from cavesim.core.twin.kernels import PORTABLE
from cavesim.core.twin.system import TwinSystem
from cavesim.gpu.engine import ParticleSystem
from cavesim.gpu.engine.programs import (
    ARITHMETIC_IDS,
    emission_defines,
    physics_defines,
)
from cavesim.gpu.shader_gate import all_builds, load_scenes, scene_files
from cavesim.gpu.shader_source import SHADER_ROOT, ProgramSpec, ShaderSource

SCENES = Path(__file__).parents[2] / "config" / "scenes"
DT = 1 / 60
DEMO_FRAMES = 500
DEMO_CAPACITY = 6_000  # either demo fills it in its first 20 frames, and overflows it after
SMALL_FRAMES = 100
SUBSTEP_ROWS = ("tracers_stepped", "substeps_taken", "substeps_retaken", "most_substeps")
PORTABLE_ID = ARITHMETIC_IDS[Arithmetic.PORTABLE]


def portable_scene(path: Path, capacity: int | None = None) -> Scene:
    """The scene file at `path` with `[simulation] arithmetic = "portable"` (and another
    capacity, if given)."""
    with open(path, "rb") as f:
        data = tomllib.load(f)
    data["simulation"]["arithmetic"] = "portable"
    if capacity is not None:
        data["simulation"]["capacity"] = capacity
    return parse_scene(data, path, path.stem)


def twin_checksum(twin: TwinSystem) -> StateChecksum:
    return reference_checksum(twin.particles.records().view(np.uint32),
                              twin.emitters.view(np.uint32), twin.scene.seed)


class Lockstep:
    """One scene in portable arithmetic on the twin and on both GPU engine paths, stepped
    with the master's inputs (its driver's frames as a node decodes them, a random texture
    transform per frame); every frame each GPU checksum must be the twin's."""

    def __init__(self, ctx, scene: Scene, start: np.ndarray | None = None) -> None:
        self.twin = TwinSystem(scene)
        assert self.twin.kernels is PORTABLE
        self.gpus = {engine: ParticleSystem(ctx, dataclasses.replace(scene, engine=engine))
                     for engine in ENGINE_PATHS}
        self.driver = driver_for(scene)
        self.rng = np.random.Generator(np.random.PCG64(0))
        self.size = scene.random_texture_size
        self.frames = 0
        self.counts: list[int] = []
        self.exits = np.zeros(len(scene.particle_classes), dtype=np.int64)  # the twin's
        self.dropped: list[int] = []  # the twin's, each frame
        self.substeps: list[SubstepCounts] = []  # the twin's adaptive tracers', each frame
        self.substeps_counted = dict.fromkeys(ENGINE_PATHS, 0)  # frames each GPU counted
        if start is not None:
            for system in (self.twin, *self.gpus.values()):
                system.write_particles(start)

    def step(self) -> None:
        self.frames += 1
        step = self.driver.advance(self.frames * DT, DT, None)
        scene_frame = self.driver.decode(self.driver.encode(step.frame))
        inputs = FrameInput(DT, draw_transform(self.rng, self.size))
        self.twin.step(inputs, scene_frame)
        expected = twin_checksum(self.twin)
        for engine, gpu in self.gpus.items():
            gpu.step(inputs, scene_frame)
            if gpu.checksum() != expected:
                pytest.fail(f"frame {self.frames}, {engine.value} path: "
                            f"{first_difference(gpu, self.twin)}")
            counted, twin = gpu.counters(), self.twin.counters()
            if counted != {name: twin[name] for name in counted}:
                pytest.fail(f"frame {self.frames}, {engine.value} path: counters {counted}, "
                            f"the twin's {twin}")
            self.substeps_counted[engine] += "tracers_stepped" in counted
        twin = self.twin.counters()
        self.counts.append(expected.particles)
        self.dropped.append(self.twin.dropped())
        if "tracers_stepped" in twin:
            self.substeps.append(SubstepCounts(*(twin[name][0] for name in SUBSTEP_ROWS)))
        self.exits += twin.get("domain_exits", 0)

    def release(self) -> None:
        for gpu in self.gpus.values():
            gpu.release()


@pytest.fixture
def lockstep(ctx):
    made: list[Lockstep] = []

    def make(scene: Scene, start: np.ndarray | None = None) -> Lockstep:
        made.append(Lockstep(ctx, scene, start))
        return made[-1]

    yield make
    for each in made:
        each.release()


def first_difference(gpu: ParticleSystem, twin: TwinSystem) -> str:
    """Where the GPU's streams first differ from the twin's: record, field, both values."""
    for stream, ours, theirs in (("particle", gpu.read_particles(), twin.particles.records()),
                                 ("emitter", gpu.read_emitters(), twin.emitters)):
        common = min(len(ours), len(theirs))
        bytes_ours, bytes_theirs = (x[:common].view(np.uint8).reshape(common, -1)
                                    for x in (ours, theirs))
        differing = np.flatnonzero((bytes_ours != bytes_theirs).any(axis=1))
        if len(differing):
            first = differing[0]
            found = differences(ours.dtype, differing[:1], ours[first:first + 1].tobytes(),
                                theirs[first:first + 1].tobytes())[0]
            (gpu_bits, twin_bits), (gpu_value, twin_value) = found.bits, found.values
            return (f"{stream} record {first} of {common} first differs in "
                    f"{found.field.name}: GPU {found.shown(gpu_value)} ({found.hex(gpu_bits)}),"
                    f" twin {found.shown(twin_value)} ({found.hex(twin_bits)}), "
                    f"{found.distance} apart; {len(differing)} records differ")
        if len(ours) != len(theirs):
            return f"{len(ours)} {stream} records on the GPU, {len(theirs)} in the twin"
    return "the streams are equal, but not their checksums"


# -- the CI test: the demos, 500 frames, both engine paths -------------------------------


@pytest.mark.slow
@pytest.mark.parametrize("name", ["brownout", "dust_devil"])
def test_the_demos_have_the_portable_twins_checksum_every_frame(lockstep, name):
    """Each demo's first 500 frames (the helicopter's approach, descent and hover; the dust
    devil's sand living out its 3-6 s) in portable arithmetic: both engine paths have the
    portable twin's checksum every frame, and at the first differing frame the record and
    field are named. At a capacity of 6,000, not the demos' 300,000: the cloud is full
    within 20 frames and the emission overflows it from then on (the particles that do not
    fit are dropped as the twin drops them), and the particles that die make room for new
    ones, in the same order. Slow: the twin repeats every float operation in numpy (at the
    demos' own capacity, up to 200,000 particles, the two took about 6 minutes on 2 cores)."""
    scene = portable_scene(SCENES / f"{name}.toml", capacity=DEMO_CAPACITY)
    run = lockstep(scene)
    for _ in range(DEMO_FRAMES):
        run.step()
    assert max(run.counts) == DEMO_CAPACITY, "the cloud must fill the capacity"
    full = run.counts.index(DEMO_CAPACITY) + 1  # the first frame that overflowed
    assert full <= 20
    # a particle younger than the time since then was emitted into room a dead one made
    assert run.twin.particles.age.min() < (DEMO_FRAMES - full - 1) * DT
    assert run.dropped.index(next(filter(None, run.dropped))) + 1 == full


def test_a_full_pool_drops_the_twins_count_on_both_paths(lockstep):
    """Two fountains into 500 places in portable arithmetic: both engine paths drop as
    many new particles as the twin, every frame, from the frame the pool fills on."""
    fountain = dict(FOUNTAIN, rate=9000.0, lifetime=[0.3, 0.4])
    data = scene_dict(emitters=[fountain, dict(fountain, name="second", rate=5000.0)],
                      capacity=500, arithmetic="portable")
    run = lockstep(parse_scene(data, name="full"))
    for _ in range(30):  # 233 new a frame: full in frame 3; from frame 20 on, room again
        run.step()
    assert run.dropped[:2] == [0, 0] and run.counts[:3] == [233, 466, 500]
    assert run.dropped[2] == 233 + 233 + 234 - 500  # what frame 3 could not place
    assert min(run.dropped[3:19]) >= 233, "full, nobody dead: all of a frame's new ones"
    assert min(run.dropped[19:]) < 233, "the first to die made room"


# -- every integrator, every force, a height field ------------------------------------


@pytest.fixture(scope="module")
def terrain(tmp_path_factory) -> dict:
    """A height-field [collision] table: a tilted, rippled ground under the vortex."""
    x = np.linspace(-4, 4, 33)
    y = np.linspace(-4, 4, 25)
    height = 0.3 + 0.15 * np.sin(x)[None, :] * np.cos(0.7 * y)[:, None] + 0.05 * x[None, :]
    path = tmp_path_factory.mktemp("terrain") / "terrain.npz"
    save_heightfield(path, HeightGrid(height.astype(np.float32), (-4.0, -4.0), (4.0, 4.0)))
    return {"kind": "heightfield", "friction": 0.2, "resilience": 0.6,
            "friction_min_speed": 0.05, "file": str(path)}


def every_feature(integrator: Integrator, collision: dict) -> Scene:
    """Drag toward the gridded vortex, gravity, damping, the ground, a fountain."""
    return parse_scene(scene_dict(integrator=integrator.value, damping=0.3, collision=collision,
                                  emitters=[FOUNTAIN], arithmetic="portable"), name="portable")


@pytest.mark.parametrize("integrator", list(Integrator), ids=lambda i: i.value)
def test_each_integrator_has_the_portable_twins_bits(lockstep, terrain, integrator):
    run = lockstep(every_feature(integrator, terrain), particle_cloud(400))
    for _ in range(SMALL_FRAMES):
        run.step()
    on_ground = run.twin.particles.pos[:, 2] < 0.7
    assert on_ground.mean() > 0.2, "the test needs particles on the ground"


@pytest.mark.parametrize("integrator", list(Integrator), ids=lambda i: i.value)
def test_drag_beyond_stokes_and_dispersion_have_the_portable_twins_bits(lockstep, terrain,
                                                                          integrator):
    """Schiller-Naumann sand and dust (the test scene's grains), dispersed over a height
    field: the drag rate, the random walk's draws and its mixing-length diffusivity."""
    data = scene_dict(integrator=integrator.value, damping=0.3, collision=terrain,
                      emitters=[FOUNTAIN], arithmetic="portable",
                      dispersion={"mixing_length": 0.7})
    run = lockstep(parse_scene(data, name="transport"), particle_cloud(300))
    assert run.twin.forces_for(np.zeros(1, np.uint32)).reynolds_per_speed is not None
    for _ in range(SMALL_FRAMES):
        run.step()


def smoke_beside_grains(lockstep, terrain, integrator: str, **simulation) -> Lockstep:
    """Smoke, a passive tracer class, beside the sand and dust every force acts on, over a
    height field (a third of the start cloud each; the fountain emits smoke), stepped
    SMALL_FRAMES in lockstep."""
    data = scene_dict(integrator=integrator, damping=0.3, collision=terrain,
                      emitters=[FOUNTAIN], arithmetic="portable")
    data["simulation"] |= simulation
    data["particle_class"] = [*data["particle_class"], SMOKE]
    data["emitter"][0]["particle_class"] = "smoke"
    start = particle_cloud(450)
    start["class_id"] = np.arange(len(start)) % 3
    run = lockstep(parse_scene(data, name="tracers"), start)
    for _ in range(SMALL_FRAMES):
        run.step()
    smoke = run.twin.particles.class_id == 2
    assert smoke.sum() > 150 and (~smoke).sum() > 150, "the test needs both kinds"
    return run


@pytest.mark.parametrize("integrator", list(Integrator), ids=lambda i: i.value)
def test_tracers_mixed_with_inertial_classes_have_the_portable_twins_bits(lockstep, terrain,
                                                                          integrator):
    """The smoke stepped by the integrator's tracer method."""
    smoke_beside_grains(lockstep, terrain, integrator.value)


@pytest.mark.slow
def test_adaptive_tracers_have_the_portable_twins_bits_and_substeps(lockstep, terrain):
    """The smoke stepped by RK45 in substeps: the same bits and the same substeps taken and
    retaken as the portable twin, on both paths, with a tolerance that makes the fast
    tracers divide their frames and grow their substeps again. Slow: the only test of the
    adaptive substeps' bits against the portable twin."""
    run = smoke_beside_grains(lockstep, terrain, "etd2rk", tracer_method="rk45",
                              tracer_tolerance=1e-9)
    assert all(run.substeps_counted[engine] == SMALL_FRAMES for engine in ENGINE_PATHS)
    last = run.substeps[-1]
    assert last.taken > last.tracers > 150 and last.retaken > 0 and 1 < last.most <= UNITS, \
        last


@pytest.mark.slow
def test_adaptive_tracers_in_a_time_series_have_the_portable_twins_bits(lockstep):
    """Smoke by RK45 in config/fields/pulsing_vortex.nc: its substeps take the flow between
    the stages, where the series' place runs linearly in time, the same on every path.
    Slow: the only test of substeps between a series' snapshots against the twin."""
    path = Path(__file__).parents[2] / "config" / "fields" / "pulsing_vortex.nc"
    smoke = dict(FOUNTAIN, position=[2.0, 0.0, 3.0], speed=0.5, speed_spread=0.2,
                 lifetime=[1.5, 2.5], particle_class="smoke")
    data = scene_dict("rk4", emitters=[smoke], capacity=3000)
    data["particle_class"] = [*data["particle_class"], SMOKE]
    data["simulation"] |= {"arithmetic": "portable", "tracer_method": "rk45",
                           "tracer_tolerance": 1e-8}
    data["field"] = {"kind": "file", "file": str(path)}
    both = lockstep(parse_scene(data, name=path.stem))
    for _ in range(SMALL_FRAMES):
        both.step()
    assert both.counts[-1] > 500
    assert sum(s.retaken for s in both.substeps) > 0, "no substep was refused"


def test_still_air_outside_the_field_has_the_portable_twins_bits(lockstep):
    data = scene_dict(integrator="rk2", emitters=[FOUNTAIN], arithmetic="portable")
    data["field"]["out_of_domain"] = "zero"
    data["field"]["box_max"] = [4.0, 4.0, 1.5]  # the fountain throws particles out of the top
    run = lockstep(parse_scene(data, name="zero"), particle_cloud(400))
    for _ in range(SMALL_FRAMES):
        run.step()
    assert (run.twin.particles.pos[:, 2] > 1.5).any()
    assert run.exits.sum() > 100, "each frame's count of those leaving the box is checked"


@pytest.mark.parametrize(("interpolation", "out_of_domain"),
                         [("catmull_rom", "zero"), ("bspline", "clamp")])
def test_smooth_fields_have_the_portable_twins_bits(lockstep, interpolation, out_of_domain):
    """The cubic interpolants' 64 texels and weights, by RK4 four times a step; the fountain
    throws particles through the top of the box, across every boundary cell."""
    data = scene_dict(integrator="rk4", emitters=[FOUNTAIN], arithmetic="portable")
    data["field"].update(interpolation=interpolation, out_of_domain=out_of_domain,
                         box_max=[4.0, 4.0, 1.5])
    run = lockstep(parse_scene(data, name=interpolation), particle_cloud(400))
    for _ in range(SMALL_FRAMES):
        run.step()
    assert (run.twin.particles.pos[:, 2] > 1.5).any()


def test_the_portable_twin_stays_close_to_the_float64_reference(terrain):
    """The portable kernels mirror the shaders, not the physics: held against the float64
    twin, a mirror of a wrong shader line would show."""
    for integrator in (Integrator.EXPONENTIAL, Integrator.RK4):
        scene = every_feature(integrator, terrain)
        portable, reference = TwinSystem(scene), TwinSystem(scene, np.float64)
        for system in (portable, reference):
            system.write_particles(particle_cloud(400))
        for k in range(60):
            frame = FrameInput(DT, draw_transform(np.random.default_rng(k), 64))
            portable.step(frame)
            reference.step(frame)
        np.testing.assert_array_equal(portable.particles.age, reference.particles.age)
        for name in ("pos", "vel"):
            np.testing.assert_allclose(getattr(portable.particles, name),
                                       getattr(reference.particles, name), rtol=1e-4, atol=1e-3)


def test_portable_arithmetic_gives_other_bits_than_native_here(ctx):
    """A portable scene compiled natively would give this driver's own bits: they differ
    from the portable ones (exp, division), so the bit-exact tests would catch it."""
    states = []
    for arithmetic in Arithmetic:
        scene = parse_scene(scene_dict(integrator="exponential", emitters=[FOUNTAIN],
                                       arithmetic=arithmetic.value), name=arithmetic.value)
        gpu = ParticleSystem(ctx, scene)
        gpu.write_particles(particle_cloud(400))
        for _ in range(10):
            gpu.step(FrameInput(DT, np.eye(3)))
        states.append(gpu.read_particles())
        gpu.release()
    native, portable = states
    assert len(native) == len(portable)
    assert native.tobytes() != portable.tobytes()
    np.testing.assert_allclose(native["pos"], portable["pos"], rtol=1e-5, atol=1e-5)


# -- what the portable shaders may contain ------------------------------------------------

# glslang's names, in its intermediate tree, for the operations whose precision the GLSL
# specification leaves to the driver: float division and the transcendental built-ins.
FORBIDDEN = re.compile(
    r"^\d+:\d+ +((?:divide|divide second child into first child) \([^)]*\bfloat\)|"
    r"(?:exp|exp2|log|log2|pow|sqrt|inverse sqrt|sine|cosine|tangent|arc \w+|hyp\. \w+|"
    r"length|normalize|distance|dot-product|mix|fma) \()", re.M)


def portable_builds() -> list[tuple[ProgramSpec, dict[str, int]]]:
    """The particle and emission programs in portable arithmetic that the shader gate checks:
    variants that together hold every line."""
    return [(build.spec, dict(build.defines)) for build in all_builds(load_scenes(scene_files()))
            if dict(build.defines).get("ARITHMETIC") == PORTABLE_ID]


def stages(builds: list[tuple[ProgramSpec, dict[str, int]]]) -> list[tuple[str, ShaderSource]]:
    return [(f"{spec.name} {stage} {defines}", source) for spec, defines in builds
            for stage, source in spec.sources(defines).items()]


def intermediate_trees(sources: list[tuple[str, ShaderSource]], folder: Path) -> dict[str, str]:
    """glslangValidator's intermediate tree (-i) of each stage, by its name."""
    extensions = {"VERTEX_SHADER": "vert", "GEOMETRY_SHADER": "geom", "COMPUTE_SHADER": "comp"}
    paths = {}
    for number, (name, source) in enumerate(sources):
        stage = next(e for macro, e in extensions.items() if f"#define {macro}\n" in source.text)
        path = folder / f"{number:03d}.{stage}"
        path.write_text(source.text)
        paths[str(path)] = name
    result = subprocess.run(["glslangValidator", "-i", *paths], capture_output=True, text=True,
                            check=False)
    assert result.returncode == 0, result.stdout[-2000:]
    trees: dict[str, list[str]] = {}
    current: list[str] = []
    for line in result.stdout.splitlines():
        if line in paths:
            current = trees.setdefault(paths[line], [])
        else:
            current.append(line)
    return {name: "\n".join(lines) for name, lines in trees.items()}


@pytest.mark.slow
@pytest.mark.requires("glslang")
def test_portable_shaders_use_no_operation_the_spec_leaves_to_the_driver(tmp_path):
    """Slow (the intermediate tree of every portable variant): the only test that reads
    what the compiler made of the portable code."""
    trees = intermediate_trees(stages(portable_builds()), tmp_path)
    assert len(trees) > 3 * 8  # every integrator in each of the 3 particle-pass stages
    found = {name: sorted({m[1] for m in FORBIDDEN.finditer(tree)})
             for name, tree in trees.items()}
    assert not any(found.values()), {name: ops for name, ops in found.items() if ops}


@pytest.mark.slow
@pytest.mark.requires("glslang")
def test_the_same_check_finds_them_in_native_arithmetic(tmp_path):
    """The check of the portable builds' operations is not blind: on the same pass in
    native arithmetic it finds the operations the spec leaves to the driver. Slow: it
    compiles a whole particle pass to glslang's tree."""
    spec, defines = portable_builds()[0]
    native = {**defines, "ARITHMETIC": ARITHMETIC_IDS[Arithmetic.NATIVE]}
    trees = intermediate_trees(stages([(spec, native)])[:1], tmp_path)
    (tree,) = trees.values()
    found = {m[1].split(" (")[0] for m in FORBIDDEN.finditer(tree)}
    assert {"exp", "divide", "length", "dot-product", "sqrt"} <= found


def test_a_portable_scene_makes_every_stream_program_and_the_twin_portable():
    scene = every_feature(Integrator.RK4, {"kind": "plane", "friction": 0.1, "resilience": 0.5})
    assert physics_defines(scene)["ARITHMETIC"] == PORTABLE_ID
    assert emission_defines(scene)["ARITHMETIC"] == PORTABLE_ID
    native = dataclasses.replace(scene, arithmetic=Arithmetic.NATIVE)
    assert physics_defines(native)["ARITHMETIC"] == ARITHMETIC_IDS[Arithmetic.NATIVE]
    assert TwinSystem(native).dtype is np.float64 and TwinSystem(scene).dtype is np.float32


def test_the_arithmetic_ids_are_the_same_on_both_sides():
    text = (SHADER_ROOT / "include" / "arithmetic.glsl").read_text()
    glsl = {name: int(value) for name, value in re.findall(r"#define ARITHMETIC_(\w+) (\d+)",
                                                            text)}
    assert glsl == {key.name: value for key, value in ARITHMETIC_IDS.items()}


ARITHMETIC_FILES = ("arithmetic.glsl", "portable_operations.glsl", "portable_functions.glsl")


def test_the_shaders_exact_constants_have_the_twins_bits():
    pattern = re.compile(r"#define (\w+) uintBitsToFloat\(0x([0-9A-Fa-f]{8})u\)")
    glsl = {}
    for path in (SHADER_ROOT / "include").glob("*.glsl"):
        if path.name not in ARITHMETIC_FILES:  # its own constants have their own test
            glsl |= {name: int(bits, 16) for name, bits in pattern.findall(path.read_text())}
    python = {name: int(np.float32(value).view(np.uint32)) for name, value
              in vars(constants).items() if name.isupper()}
    assert glsl == python


def test_a_lockstep_mismatch_names_the_record_and_field(ctx):
    scene = every_feature(Integrator.EXPLICIT_EULER, {"kind": "plane", "friction": 0.1,
                                                      "resilience": 0.5})
    gpu, twin = ParticleSystem(ctx, scene), TwinSystem(scene)
    records = particle_cloud(5)
    gpu.write_particles(records)
    changed = records.copy()
    changed["vel"][3, 1] = np.nextafter(changed["vel"][3, 1], np.float32(np.inf))
    twin.write_particles(changed)
    message = first_difference(gpu, twin)
    twin.write_particles(records[:4])
    shorter = first_difference(gpu, twin)
    gpu.release()
    assert message.startswith("particle record 3 of 5 first differs in vel.y: GPU ")
    assert message.endswith(", 1 apart; 1 records differ")
    assert shorter == "5 particle records on the GPU, 4 in the twin"


@pytest.mark.parametrize("sample", ["vortex.nc", "vortex.vti"])
def test_a_field_from_netcdf_or_vtk_drives_a_scene_with_the_twins_bits(lockstep, sample):
    """config/fields' samples (a NetCDF file with CF attributes, a VTK image) end to end:
    read by the scene loader, their box and grid from the file, the GPU stepping the
    portable twin's bits on both engine paths while dust swirls in the vortex."""
    path = Path(__file__).parents[2] / "config" / "fields" / sample
    dust = dict(FOUNTAIN, position=[2.0, 0.0, 3.0], speed=0.5, speed_spread=0.2,
                lifetime=[1.5, 2.5], particle_class="dust")
    data = scene_dict("etd2rk", emitters=[dust], capacity=3000)
    data["simulation"]["arithmetic"] = "portable"
    data["field"] = {"kind": "file", "file": str(path), "interpolation": "catmull_rom"}
    scene = parse_scene(data, name=path.stem)
    assert (scene.field.box_min, scene.field.box_max) == ((-6.0, -6.0, 0.0), (6.0, 6.0, 10.0))
    both = lockstep(scene)
    for _ in range(SMALL_FRAMES):
        both.step()
    assert both.counts[-1] > 500
    assert np.abs(both.twin.particles.vel[:, :2]).max() > 0.5, "the vortex turns them"


def test_a_netcdf_time_series_drives_a_scene_with_the_twins_bits(lockstep):
    """config/fields/pulsing_vortex.nc: 9 snapshots 0.5 s apart, linear in time between
    them at every stage of RK4's step (start, middle, end), on both engine paths; the
    master's clock moves the pair each 0.5 s."""
    path = Path(__file__).parents[2] / "config" / "fields" / "pulsing_vortex.nc"
    dust = dict(FOUNTAIN, position=[2.0, 0.0, 3.0], speed=0.5, speed_spread=0.2,
                lifetime=[1.5, 2.5], particle_class="dust")
    data = scene_dict("rk4", emitters=[dust], capacity=3000)
    data["simulation"]["arithmetic"] = "portable"
    data["field"] = {"kind": "file", "file": str(path)}
    scene = parse_scene(data, name=path.stem)
    assert scene.field.times == tuple(0.5 * k for k in range(9))
    both = lockstep(scene)
    pairs = set()
    for _ in range(SMALL_FRAMES):
        both.step()
        pairs.add(both.driver.advance(both.frames * DT, DT, None).frame.field_time.pairs)
    assert {pair for stages in pairs for pair in stages} == {0, 1, 2, 3}
    assert any(len(set(stages)) > 1 for stages in pairs), "a step crosses a snapshot"
    assert both.counts[-1] > 500
