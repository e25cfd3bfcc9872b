"""Scene loading: the example scenes, a full round trip, and one case per rule of the schema."""

from __future__ import annotations

import copy
import math
import tomllib
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from cavesim.core.errors import SceneError
from cavesim.core.features.collision import Collision, CollisionKind
from cavesim.core.features.dispersion import Dispersion
from cavesim.core.features.stokes_drag import Drag
from cavesim.core.limits import MAX_EMITTERS, MAX_PARTICLE_CLASSES, MAX_PARTICLES
from cavesim.core.scene import (
    AIR_VISCOSITY,
    DragLaw,
    Emitter,
    Field,
    FieldInterpolation,
    FieldKind,
    FieldSampling,
    Forces,
    Integrator,
    OutOfDomain,
    ParticleClass,
    Scene,
    load_scene,
    parse_scene,
)

SCENES = Path(__file__).resolve().parents[2] / "config" / "scenes"
EXAMPLES = sorted(SCENES.glob("*.toml"))

# Every key of the schema set, mostly to non-default values.
FULL_TOML = """
name = "full"
[simulation]
capacity = 2000
seed = 99
integrator = "rk4"
random_texture_size = 64

[[particle_class]]
name = "sand"
diameter = 150e-6
density = 2650.0
drag = "stokes"

[[particle_class]]
name = "dust"
diameter = 1e-5
density = 2000

[[emitter]]
name = "a"
position = [1, 2.5, 3]
extent = [1.0, 2.0, 0.0]
rate = 500.0
speed = 2.0
speed_spread = 0.5
direction = [0.0, 3.0, 4.0]
spread_angle = 20.0
lifetime = [2.0, 4.0]
particle_class = "dust"

[[emitter]]
name = "b"
position = [0.0, 0.0, 0.0]
rate = 10
lifetime = [1.0, 1.0]
particle_class = "sand"

[forces]
gravity = [0.0, 0.0, -9.81]
damping = 0.5
[forces.drag]
air_viscosity = 2e-5
air_density = 1.2
[forces.dispersion]
mixing_length = 2.0

[field]
kind = "vortex"
box_min = [-5.0, -5.0, 0.0]
box_max = [5.0, 5.0, 5.0]
resolution = [32, 32, 16]
out_of_domain = "zero"
sampling = "hardware"
[field.params]
center = [1.0, -1.0]
circulation = -30.0
core_radius = 1.5
axial_speed = 0.25

[collision]
kind = "plane"
friction = 0.3
resilience = 0.4
friction_min_speed = 0.05
height = -0.5
"""

FULL_EXPECTED = dict(
    name="full",
    capacity=2000,
    seed=99,
    integrator=Integrator.RK4,
    random_texture_size=64,
    particle_classes=(ParticleClass("sand", 150e-6, 2650.0, DragLaw.STOKES),  # as named
                      ParticleClass("dust", 1e-5, 2000.0, DragLaw.STOKES)),  # Re ~ 0.003
    emitters=(
        Emitter(name="a", position=(1.0, 2.5, 3.0), extent=(1.0, 2.0, 0.0), rate=500.0,
                speed=2.0, speed_spread=0.5, direction=(0.0, 0.6, 0.8), spread_angle=20.0,
                lifetime=(2.0, 4.0), particle_class=1),
        Emitter(name="b", position=(0.0, 0.0, 0.0), extent=(0.0, 0.0, 0.0), rate=10.0,
                speed=0.0, speed_spread=0.0, direction=(0.0, 0.0, 1.0), spread_angle=0.0,
                lifetime=(1.0, 1.0), particle_class=0),
    ),
    forces=Forces(gravity=(0.0, 0.0, -9.81), drag=Drag(2e-5, 1.2), damping=0.5,
                  dispersion=Dispersion(2.0)),
    field=Field(kind=FieldKind.VORTEX, box_min=(-5.0, -5.0, 0.0), box_max=(5.0, 5.0, 5.0),
                resolution=(32, 32, 16), out_of_domain=OutOfDomain.ZERO,
                sampling=FieldSampling.HARDWARE,
                params={"center": (1.0, -1.0), "circulation": -30.0, "core_radius": 1.5,
                        "axial_speed": 0.25}),
    collision=Collision(kind=CollisionKind.PLANE, friction=0.3, resilience=0.4,
                        friction_min_speed=0.05, height=-0.5),
)


def write(tmp_path: Path, text: str, name: str = "scene.toml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def save_velocity(path: Path, shape: tuple[int, ...]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez(path, velocity=np.zeros(shape, dtype=np.float32))


# --- the example scenes ---------------------------------------------------------------


def test_examples_exist() -> None:
    assert {p.stem for p in EXAMPLES} >= {"minimal", "dust_devil", "bench"}


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_example_loads(path: Path) -> None:
    scene = load_scene(path)
    assert scene.name == path.stem
    assert scene.source == path
    assert path.read_text(encoding="utf-8").startswith("#"), "needs a comment header"
    # Emitters cannot outrun the pool: peak live count <= capacity.
    assert sum(e.rate * e.lifetime[1] for e in scene.emitters) <= scene.capacity


def test_minimal_has_only_gravity() -> None:
    scene = load_scene(SCENES / "minimal.toml")
    assert (scene.capacity, scene.seed) == (10000, 1)
    assert scene.integrator is Integrator.SEMI_IMPLICIT_EULER
    assert scene.forces == Forces(gravity=(0.0, 0.0, -9.81))
    assert scene.field is None and scene.collision is None
    assert len(scene.particle_classes) == 1 and len(scene.emitters) == 1


def test_dust_devil() -> None:
    scene = load_scene(SCENES / "dust_devil.toml")
    assert scene.integrator is Integrator.ETD2RK and scene.capacity == 300000
    assert scene.field is not None and scene.field.kind is FieldKind.VORTEX
    assert scene.forces.drag is not None and scene.forces.gravity is not None
    assert scene.collision is not None and scene.collision.kind is CollisionKind.PLANE
    assert len(scene.particle_classes) == 2 and len(scene.emitters) == 2
    taus = dict(zip((c.name for c in scene.particle_classes), scene.relaxation_times(),
                    strict=True))
    assert taus["dust"] == pytest.approx(0.8e-3, rel=0.05)
    assert taus["sand"] > 100 * taus["dust"]


def test_bench() -> None:
    scene = load_scene(SCENES / "bench.toml")
    assert scene.capacity == 1_000_000 and scene.integrator is Integrator.RK2
    f = scene.forces
    assert f.drag is not None and f.gravity is not None and f.damping is not None
    assert scene.field is not None and scene.field.resolution == (32, 32, 32)
    assert scene.collision is not None and scene.collision.kind is CollisionKind.PLANE


def test_a_scene_extends_its_base_key_by_key_and_scales_its_emitters(tmp_path: Path) -> None:
    write(tmp_path, FULL_TOML, "full.toml")
    path = write(tmp_path, 'base = "full.toml"\nname = "more"\nemission_scale = 3.0\n'
                           '[simulation]\ncapacity = 5000\n[forces]\ngravity = [0, 0, -1]\n',
                 "more.toml")
    full, more = load_scene(tmp_path / "full.toml"), load_scene(path)
    assert (more.name, more.capacity) == ("more", 5000)
    assert (more.seed, more.integrator) == (full.seed, full.integrator)  # [simulation] merged
    assert more.forces.gravity == (0.0, 0.0, -1.0) and more.forces.drag == full.forces.drag
    assert [e.rate for e in more.emitters] == [3 * e.rate for e in full.emitters]
    assert more.emitters[0].position == full.emitters[0].position


@pytest.mark.parametrize(("text", "needles"), [
    ('base = 3\n', ("base = 3 is not allowed", "path of a scene file")),
    ('base = "nowhere.toml"\n', ("nowhere.toml", "cannot read base scene file")),
    ('base = "twice.toml"\n', ("has a base of its own", "one file at most")),
    ('base = "full.toml"\nemission_scale = 2e6\n', ("emission_scale", "<= 1e+06")),
    ('base = "fast.toml"\nemission_scale = 1e6\n', ("emission_scale", "rate 5e+09 per second",
                                                     "at most 1e+09")),
    ('base = "full.toml"\nemission_scale = 0\n', ("emission_scale", "> 0")),
])
def test_a_bad_base_or_scale_is_one_line(tmp_path: Path, text: str,
                                         needles: tuple[str, ...]) -> None:
    write(tmp_path, FULL_TOML.replace("rate = 500.0", "rate = 5000.0"), "fast.toml")
    write(tmp_path, FULL_TOML, "full.toml")
    write(tmp_path, 'base = "full.toml"\n', "twice.toml")
    with pytest.raises(SceneError) as error:
        load_scene(write(tmp_path, text, "child.toml"))
    assert "\n" not in str(error.value)
    assert all(needle in str(error.value) for needle in needles), str(error.value)


def test_dust_relaxation_time() -> None:
    dust = ParticleClass("dust", diameter=10e-6, density=2650.0)
    assert dust.relaxation_time() == pytest.approx(0.8e-3, rel=0.05)


# --- round trips ------------------------------------------------------------------------


def test_round_trip_every_field(tmp_path: Path) -> None:
    path = write(tmp_path, FULL_TOML)
    scene = load_scene(path)
    expected = Scene(source=path, **FULL_EXPECTED)
    for name in Scene.__dataclass_fields__:  # one assert per field names the broken one
        assert getattr(scene, name) == getattr(expected, name), name
    assert all(type(x) is float for x in scene.emitters[0].position)
    assert scene.emitters[0].direction == pytest.approx((0.0, 0.6, 0.8))
    assert math.hypot(*scene.emitters[0].direction) == pytest.approx(1.0)


def test_defaults(tmp_path: Path) -> None:
    path = write(tmp_path, "[simulation]\ncapacity = 0\nseed = 0\n", name="bare.toml")
    scene = load_scene(str(path))
    assert scene == Scene(name="bare", source=path, capacity=0, seed=0,
                          integrator=Integrator.ETD2RK, random_texture_size=256,
                          particle_classes=(), emitters=(), forces=Forces(), field=None,
                          collision=None)
    assert parse_scene({"simulation": {"capacity": 1, "seed": 2}}).name == "scene"
    drag = parse_scene({"simulation": {"capacity": 1, "seed": 2}, "forces": {"drag": {}},
                        "field": {"kind": "uniform", "box_min": [0, 0, 0], "box_max": [1, 1, 1],
                                  "resolution": [2, 2, 2], "params": {"velocity": [1, 0, 0]}}})
    assert drag.forces.drag == Drag(AIR_VISCOSITY)
    assert drag.field is not None and drag.field.out_of_domain is OutOfDomain.CLAMP
    assert drag.field.sampling is FieldSampling.MANUAL
    assert drag.field.interpolation is FieldInterpolation.TRILINEAR


def test_downwash_params_defaults() -> None:
    data = tomllib.loads(FULL_TOML)
    data["field"]["params"] = {"rotor_center": [0, 0, 3], "rotor_radius": 1,
                               "induced_velocity": 0}
    data["field"]["kind"] = "downwash"
    params = parse_scene(data).field.params  # type: ignore[union-attr]
    assert params == {"rotor_center": (0.0, 0.0, 3.0), "rotor_radius": 1.0,
                      "induced_velocity": 0.0, "ground_height": 0.0}
    assert all(type(v) in (float, tuple) for v in params.values())


def test_file_field_and_heightfield_resolve_relative_to_toml(tmp_path: Path) -> None:
    save_velocity(tmp_path / "fields" / "flow.npz", (6, 5, 4, 3))  # (nz, ny, nx, 3)
    np.savez(tmp_path / "fields" / "terrain.npz", height=np.zeros((3, 3), np.float32))
    data = tomllib.loads(FULL_TOML)
    data["field"] = {"kind": "file", "box_min": [0, 0, 0], "box_max": [1, 1, 1],
                     "file": "fields/flow.npz"}
    data["collision"] = {"kind": "heightfield", "friction": 0, "resilience": 1,
                         "file": "fields/terrain.npz"}
    text = FULL_TOML.split("[field]")[0] + """
[field]
kind = "file"
box_min = [0, 0, 0]
box_max = [1, 1, 1]
file = "fields/flow.npz"

[collision]
kind = "heightfield"
friction = 0
resilience = 1
file = "fields/terrain.npz"
"""
    scene = load_scene(write(tmp_path, text))
    assert scene.field is not None and scene.collision is not None
    assert scene.field.file == tmp_path / "fields" / "flow.npz"
    assert scene.field.resolution == (4, 5, 6) and scene.field.params == {}
    assert scene.collision.file == tmp_path / "fields" / "terrain.npz"
    assert scene.collision.height == 0.0
    # The same dict from another working directory's point of view: the file is not there.
    with pytest.raises(SceneError, match=r"field\.file = 'fields/flow\.npz'"):
        parse_scene(data, tmp_path / "elsewhere" / "scene.toml")


# --- bad input ---------------------------------------------------------------------------

Mutation = Callable[[dict[str, Any]], None]


def _set(path: str, value: object) -> Mutation:
    """A mutation setting the dotted `path` (list items as `emitter.1.rate`) to `value`."""
    *parents, last = path.split(".")

    def apply(d: dict[str, Any]) -> None:
        node: Any = d
        for p in parents:
            node = node[int(p)] if isinstance(node, list) else node[p]
        node[int(last) if isinstance(node, list) else last] = value
    return apply


def _delete(path: str) -> Mutation:
    *parents, last = path.split(".")

    def apply(d: dict[str, Any]) -> None:
        node: Any = d
        for p in parents:
            node = node[int(p)] if isinstance(node, list) else node[p]
        del node[last]
    return apply


def _file_field(d: dict[str, Any]) -> None:
    d["field"] = {"kind": "file", "box_min": [0, 0, 0], "box_max": [1, 1, 1],
                  "file": "fields/missing.npz"}


def _copies(key: str, total: int) -> Mutation:
    """Grow the `key` tables to `total`, each copy of the first under its own name."""

    def apply(d: dict[str, Any]) -> None:
        first = d[key][0]
        d[key] += [dict(first, name=f"{first['name']}{i}") for i in range(total - len(d[key]))]
    return apply


BAD: list[tuple[str, Mutation, tuple[str, ...]]] = [
    # (id, mutation of the full scene, substrings the message must hold: key and value)
    ("unknown-top-key", _set("colour", "red"), ("colour", "'red'", "simulation")),
    ("unknown-emitter-key", _set("emitter.1.rte", 5.0), ("emitter[1].rte", "5.0", "rate")),
    ("unknown-param", _set("field.params.radius", 2.0), ("field.params.radius", "2.0",
                                                         "core_radius")),
    ("unknown-drag-key", _set("forces.drag.mu", 1e-5), ("forces.drag.mu", "1e-05")),
    ("string-for-int", _set("simulation.capacity", "1000"), ("simulation.capacity", "'1000'")),
    ("float-for-int", _set("simulation.capacity", 1e5), ("simulation.capacity", "100000.0")),
    ("string-for-number", _set("emitter.0.speed", "fast"), ("emitter[0].speed", "'fast'")),
    ("bool-for-number", _set("emitter.0.rate", True), ("emitter[0].rate", "True")),
    ("bool-for-int", _set("simulation.seed", False), ("simulation.seed", "False")),
    ("bool-in-vector", _set("emitter.0.position", [0.0, True, 0.0]),
     ("emitter[0].position", "[0.0, True, 0.0]")),
    ("nan-density", _set("particle_class.0.density", math.nan),
     ("particle_class[0].density", "nan")),
    ("inf-gravity", _set("forces.gravity", [0.0, 0.0, -math.inf]),
     ("forces.gravity", "[0.0, 0.0, -inf]")),
    ("vector-too-short", _set("field.box_min", [0.0, 0.0]), ("field.box_min", "[0.0, 0.0]")),
    ("negative-rate", _set("emitter.1.rate", -5.0), ("emitter[1].rate", "-5.0", ">= 0")),
    ("rate-too-high", _set("emitter.1.rate", 2e9), ("emitter[1].rate", "2000000000.0")),
    ("lifetime-min-gt-max", _set("emitter.0.lifetime", [4.0, 2.0]),
     ("emitter[0].lifetime", "[4.0, 2.0]")),
    ("lifetime-zero", _set("emitter.0.lifetime", [0.0, 2.0]),
     ("emitter[0].lifetime", "[0.0, 2.0]")),
    ("speed-spread-gt-speed", _set("emitter.0.speed_spread", 3.0),
     ("emitter[0].speed_spread", "3.0", "emitter[0].speed = 2.0")),
    ("direction-zero", _set("emitter.0.direction", [0, 0, 0]),
     ("emitter[0].direction", "[0, 0, 0]")),
    ("spread-angle", _set("emitter.0.spread_angle", 181.0), ("emitter[0].spread_angle", "181.0")),
    ("negative-extent", _set("emitter.0.extent", [1.0, -1.0, 0.0]),
     ("emitter[0].extent", "[1.0, -1.0, 0.0]")),
    ("diameter-too-big", _set("particle_class.0.diameter", 0.2),
     ("particle_class[0].diameter", "0.2")),
    ("capacity-too-big", _set("simulation.capacity", MAX_PARTICLES + 1),
     ("simulation.capacity", str(MAX_PARTICLES + 1), "53687091")),
    ("capacity-negative", _set("simulation.capacity", -1), ("simulation.capacity", "-1")),
    ("seed-too-big", _set("simulation.seed", 2**63), ("simulation.seed", str(2**63))),
    ("texture-not-power-of-two", _set("simulation.random_texture_size", 300),
     ("simulation.random_texture_size", "300", "power of two")),
    ("texture-too-small", _set("simulation.random_texture_size", 8),
     ("simulation.random_texture_size", "8")),
    ("unknown-integrator", _set("simulation.integrator", "rk3"),
     ("simulation.integrator", "'rk3'", "'rk4'")),
    ("unknown-arithmetic", _set("simulation.arithmetic", "exact"),
     ("simulation.arithmetic", "'exact'", "'native', 'portable'")),
    ("portable-with-hardware-sampling", _set("simulation.arithmetic", "portable"),
     ("field.sampling", "'hardware'", '"manual"', "portable", "vendor")),
    ("missing-capacity", _delete("simulation.capacity"), ("simulation.capacity", "missing")),
    ("missing-simulation", _delete("simulation"), ("simulation", "missing")),
    ("empty-name", _set("name", ""), ("name", "''")),
    ("duplicate-class", _set("particle_class.1.name", "sand"), ("particle_class[1].name",
                                                                "'sand'", "particle_class[0]")),
    ("duplicate-emitter", _set("emitter.1.name", "a"), ("emitter[1].name", "'a'", "emitter[0]")),
    ("unknown-class-ref", _set("emitter.0.particle_class", "gravel"),
     ("emitter[0].particle_class", "'gravel'", "'sand'")),
    ("emitters-without-classes", _delete("particle_class"),
     ("emitter[0].particle_class", "'dust'", "none are defined")),
    ("class-not-array", _set("particle_class", {"name": "x"}), ("particle_class", "{'name': 'x'}")),
    ("drag-without-field", _delete("field"), ("field", "forces.drag", "missing")),
    ("field-without-drag", _delete("forces.drag"), ("field", "forces.drag", "'vortex'", "missing")),
    ("damping-zero", _set("forces.damping", 0.0), ("forces.damping", "0.0", "> 0")),
    ("viscosity-negative", _set("forces.drag.air_viscosity", -1.0),
     ("forces.drag.air_viscosity", "-1.0")),
    ("missing-file", _file_field, ("field.file", "'fields/missing.npz'", "missing.npz")),
    ("file-on-analytic-field", _set("field.file", "x.npz"), ("field.file", "'x.npz'", "vortex")),
    ("param-missing", _delete("field.params.core_radius"), ("field.params.core_radius",
                                                            "missing")),
    ("params-missing", _delete("field.params"), ("field.params.center", "missing")),
    ("rotor-below-ground", _set("field", {
        "kind": "downwash", "box_min": [0, 0, 0], "box_max": [1, 1, 1], "resolution": [2, 2, 2],
        "params": {"rotor_center": [0, 0, 0.5], "rotor_radius": 1.0, "induced_velocity": 5.0,
                   "ground_height": 0.5}}),
     ("field.params.rotor_center", "[0, 0, 0.5]", "ground_height")),
    ("param-core-radius-zero", _set("field.params.core_radius", 0.0),
     ("field.params.core_radius", "0.0")),
    ("param-wrong-kind", _set("field.kind", "uniform"),
     ("field.params.center", "[1.0, -1.0]", "velocity")),
    ("unknown-field-kind", _set("field.kind", "spiral"), ("field.kind", "'spiral'", "'vortex'")),
    ("box-max-le-min", _set("field.box_max", [5.0, -5.0, 5.0]),
     ("field.box_max", "[5.0, -5.0, 5.0]", "field.box_min")),
    ("resolution-too-fine", _set("field.resolution", [257, 2, 2]),
     ("field.resolution", "[257, 2, 2]")),
    ("resolution-too-many-nodes", _set("field.resolution", [256, 256, 128]),
     ("field.resolution", "[256, 256, 128]", str(2**22))),
    ("resolution-floats", _set("field.resolution", [32.0, 32, 16]),
     ("field.resolution", "[32.0, 32, 16]")),
    ("resolution-missing", _delete("field.resolution"), ("field.resolution", "missing")),
    ("out-of-domain", _set("field.out_of_domain", "wrap"), ("field.out_of_domain", "'wrap'")),
    ("unknown-interpolation", _set("field.interpolation", "cubic"),
     ("field.interpolation", "'cubic'", "'trilinear', 'catmull_rom', 'bspline'")),
    ("hardware-sampling-with-a-cubic", _set("field.interpolation", "bspline"),
     ("field.interpolation", "'bspline'", '"trilinear"', 'sampling = "hardware"')),
    ("friction-above-one", _set("collision.friction", 1.5), ("collision.friction", "1.5")),
    ("resilience-string", _set("collision.resilience", "0.4"), ("collision.resilience", "'0.4'")),
    ("heightfield-with-height", _set("collision.kind", "heightfield"),
     ("collision.height", "-0.5", "plane")),
    ("plane-with-file", _set("collision.file", "t.npz"), ("collision.file", "'t.npz'")),
    ("drag-law-unknown", _set("particle_class.0.drag", "newton"),
     ("particle_class[0].drag", "'newton'", "schiller_naumann")),
    ("air-density-zero", _set("forces.drag.air_density", 0.0), ("forces.drag.air_density",)),
    ("mixing-length-negative", _set("forces.dispersion.mixing_length", -1.0),
     ("forces.dispersion.mixing_length", "-1.0")),
    ("dispersion-without-drag", lambda d: (d["forces"].pop("drag"), d.pop("field")),
     ("forces.dispersion", "forces.drag")),
    ("dispersion-without-collision", _delete("collision"),
     ("forces.dispersion", "[collision]", "height above the ground")),
    ("dispersion-capacity-beyond-words", _set("simulation.capacity", 4 * 64**2 + 1),
     ("simulation.capacity", "16385", "<= 16384", "random_texture_size")),
    ("too-many-classes", _copies("particle_class", MAX_PARTICLE_CLASSES + 1),
     ("particle_class", f"{MAX_PARTICLE_CLASSES + 1} [[particle_class]]", "at most 64")),
    ("too-many-emitters", _copies("emitter", MAX_EMITTERS + 1),
     ("emitter", f"{MAX_EMITTERS + 1} [[emitter]]", f"at most {MAX_EMITTERS}")),
]


@pytest.mark.parametrize(("mutate", "needles"), [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_bad_input(tmp_path: Path, mutate: Mutation, needles: tuple[str, ...]) -> None:
    data = copy.deepcopy(tomllib.loads(FULL_TOML))
    parse_scene(copy.deepcopy(data), tmp_path / "bad.toml")  # the unmutated scene is fine
    mutate(data)
    with pytest.raises(SceneError) as info:
        parse_scene(data, tmp_path / "bad.toml")
    message = str(info.value)
    assert message.startswith(f"{tmp_path / 'bad.toml'}: "), message
    for needle in needles:
        assert needle in message, f"{needle!r} not in {message!r}"


def test_dict_source_is_named() -> None:
    with pytest.raises(SceneError, match=r"^<dict>: simulation\.seed = -1 is not allowed: "):
        parse_scene({"simulation": {"capacity": 1, "seed": -1}})


@pytest.mark.parametrize(("snippet", "needles"), [
    ("rate = true", ("emitter[1].rate", "True")),
    ("rate = nan", ("emitter[1].rate", "nan")),
    ("rate = -inf", ("emitter[1].rate", "-inf")),
    ("rate = -5.0", ("emitter[1].rate = -5.0 is not allowed: must be a finite number >= 0",)),
], ids=["bool", "nan", "inf", "negative"])
def test_bad_value_in_file(tmp_path: Path, snippet: str, needles: tuple[str, ...]) -> None:
    path = write(tmp_path, FULL_TOML.replace("rate = 10", snippet))
    with pytest.raises(SceneError) as info:
        load_scene(path)
    assert str(info.value).startswith(f"{path}: ")
    for needle in needles:
        assert needle in str(info.value)


def test_toml_syntax_error_names_file_and_chains(tmp_path: Path) -> None:
    path = write(tmp_path, FULL_TOML.replace("seed = 99", "seed = = 99"))
    with pytest.raises(SceneError, match="not valid TOML") as info:
        load_scene(path)
    assert str(path) in str(info.value) and "line 5" in str(info.value)
    assert isinstance(info.value.__cause__, tomllib.TOMLDecodeError)


def test_missing_scene_file(tmp_path: Path) -> None:
    path = tmp_path / "nope.toml"
    with pytest.raises(SceneError, match="cannot read scene file") as info:
        load_scene(path)
    assert str(path) in str(info.value)
    assert isinstance(info.value.__cause__, FileNotFoundError)


@pytest.mark.parametrize(("shape", "needle"), [
    ((4, 4, 4), "(4, 4, 4)"),
    ((1, 4, 4, 3), "(1, 4, 4, 3)"),
    ((2, 2, 300, 3), "(2, 2, 300, 3)"),
    ((2, 2, 2, 2), "(2, 2, 2, 2)"),
], ids=["no-components", "one-layer", "too-fine", "two-components"])
def test_field_file_shape(tmp_path: Path, shape: tuple[int, ...], needle: str) -> None:
    save_velocity(tmp_path / "f.npz", shape)
    data = tomllib.loads(FULL_TOML)
    data["field"] = {"kind": "file", "box_min": [0, 0, 0], "box_max": [1, 1, 1],
                     "file": "f.npz"}
    with pytest.raises(SceneError) as info:
        parse_scene(data, tmp_path / "s.toml")
    assert "field.file = 'f.npz'" in str(info.value) and needle in str(info.value)


def test_field_file_not_npz(tmp_path: Path) -> None:
    (tmp_path / "f.npz").write_text("not a zip")
    data = tomllib.loads(FULL_TOML)
    data["field"] = {"kind": "file", "box_min": [0, 0, 0], "box_max": [1, 1, 1],
                     "file": "f.npz", "resolution": [2, 2, 2]}
    with pytest.raises(SceneError, match=r"field\.resolution = \[2, 2, 2\].*file decides"):
        parse_scene(data, tmp_path / "s.toml")
    del data["field"]["resolution"]
    with pytest.raises(SceneError, match=r"field\.file = 'f\.npz'") as info:
        parse_scene(data, tmp_path / "s.toml")
    assert info.value.__cause__ is not None
    save_velocity(tmp_path / "g.npz", (2, 2, 2, 3))
    data["field"]["file"] = "g.npz"
    data["field"]["params"] = {"velocity": [1, 0, 0]}
    with pytest.raises(SceneError, match=r"field\.params\.velocity = \[1, 0, 0\].*none"):
        parse_scene(data, tmp_path / "s.toml")
