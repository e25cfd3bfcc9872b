"""A feature the scene lacks compiles to no code and allocates nothing."""

import re
from pathlib import Path

import moderngl
import numpy as np
import pytest
from scenes import FOUNTAIN, VORTEX_FIELD, make_scene, scene_dict, with_smoke

from cavesim.core.errors import ShaderError
from cavesim.core.scene import load_scene, parse_scene
from cavesim.gpu.engine import FrameInput, ParticleSystem
from cavesim.gpu.engine.programs import PARTICLE_UPDATE, physics_defines
from cavesim.gpu.engine.uniforms import write_uniforms

SCENES = Path(__file__).parents[2] / "config" / "scenes"
FEATURE_CODE = {  # what each feature puts in the compiled particle pass
    "drag": ("flow_field", "texelFetch", "inv_tau"),
    "damping": ("damping",),
    "collision": ("friction", "resilience", "collide"),
    "heightfield": ("ground_height",),
    "exponential": ("exponential_weights",),
    "schiller_naumann": ("reynolds_per_speed", "step_reynolds_per_speed"),
    "dispersion": ("mixing_length", "random_texture", "turbulence_seen", "step_turbulence"),
    "tracers": ("tracer_classes", "is_tracer", "trace"),
}


def compiled_text(scene) -> str:
    """The particle pass's vertex stage as the compiler sees it, inactive branches removed."""
    source = PARTICLE_UPDATE.sources(physics_defines(scene))["vertex"].text
    return re.sub(r"//[^\n]*", "", _active_lines(source))  # code, not comments


def mentions(text: str, word: str) -> bool:
    return re.search(rf"\b{word}\b", text) is not None


def uniforms(program) -> set[str]:
    return {name for name in program if isinstance(program[name], moderngl.Uniform)}


def _active_lines(source: str) -> str:
    macros: dict[str, str] = {}
    stack: list[tuple[bool, bool]] = []  # (this branch active, some branch already taken)
    out = []
    for line in source.splitlines():
        directive = re.match(r"\s*#\s*(if|elif|else|endif|define)\b\s*(.*)", line)
        active = all(a for a, _ in stack)
        if not directive:
            if active:
                out.append(line)
            continue
        kind, rest = directive.groups()
        if kind == "define" and active:
            name, _, value = rest.partition(" ")
            macros[name] = value.strip()
        elif kind == "if":
            taken = active and _holds(rest, macros)
            stack.append((taken, taken))
        elif kind in ("elif", "else"):
            _, taken = stack.pop()
            parent = all(a for a, _ in stack)
            now = parent and not taken and (kind == "else" or _holds(rest, macros))
            stack.append((now, taken or now))
        elif kind == "endif":
            stack.pop()
    return "\n".join(out)


def _holds(condition: str, macros: dict[str, str]) -> bool:
    condition = condition.split("//")[0].strip()
    if condition.startswith("defined"):
        return condition.split()[-1] in macros
    match = re.fullmatch(r"(\w+)\s*(==|!=)\s*(\w+)", condition)
    if match:
        left, op, right = match.groups()
        equal = macros.get(left, left) == macros.get(right, right)
        return equal if op == "==" else not equal
    return macros.get(condition, "0") != "0"


def test_minimal_scene_compiles_to_gravity_and_nothing_else():
    scene = load_scene(SCENES / "minimal.toml")
    text = compiled_text(scene)
    assert mentions(text, "gravity")
    for feature, words in FEATURE_CODE.items():
        for word in words:
            assert not mentions(text, word), f"{feature}: {word!r} is in the minimal scene"


def test_full_scene_compiles_its_features(tmp_path):
    text = compiled_text(make_scene(integrator="exponential", damping=0.2, collision={
        "kind": "plane", "friction": 0.1, "resilience": 0.5}))
    for feature in ("drag", "damping", "collision", "exponential"):
        for word in FEATURE_CODE[feature]:
            assert mentions(text, word), f"{feature}: {word!r} missing"


def test_drag_laws_and_dispersion_compile_in_where_a_scene_has_them(ctx):
    """The test scene's grains of 400 and 100 um get Schiller-Naumann (the loader's rule)
    unless named Stokes; only a scene with [forces.dispersion] draws from the random
    texture in its particle pass."""
    plane = {"kind": "plane", "friction": 0.1, "resilience": 0.5}
    data = scene_dict(collision=plane)
    data["particle_class"] = [dict(c, drag="stokes") for c in data["particle_class"]]
    stokes = parse_scene(data, name="stokes")
    both = make_scene(collision=plane, dispersion={"mixing_length": 1.0})
    assert {c.drag.value for c in both.particle_classes} == {"schiller_naumann"}
    for scene, present in ((stokes, ()), (both, ("schiller_naumann", "dispersion"))):
        text = compiled_text(scene)
        for feature in ("schiller_naumann", "dispersion"):
            for word in FEATURE_CODE[feature]:
                assert mentions(text, word) == (feature in present), (feature, word)
    system = ParticleSystem(ctx, both)  # no emitters: the texture is dispersion's
    assert "random_texture" in system.resources
    assert {"reynolds_per_speed", "mixing_length", "random_texture", "random_transform"} <= \
        uniforms(system.particle_program)


def test_only_a_scene_with_a_tracer_class_compiles_the_tracer_branch(ctx):
    inertial = make_scene(integrator="rk4")
    tracers = parse_scene(with_smoke(scene_dict(integrator="rk4")), name="tracers")
    for scene in (inertial, tracers):
        text = compiled_text(scene)
        for word in FEATURE_CODE["tracers"]:
            assert mentions(text, word) == (scene is tracers), word
    system = ParticleSystem(ctx, tracers)
    assert "tracer_classes" in uniforms(system.particle_program)
    assert tuple(system.particle_program["tracer_classes"].value) == (0b10, 0)
    system.release()


@pytest.mark.parametrize("interpolation", ["trilinear", "catmull_rom", "bspline"])
def test_only_a_cubic_interpolation_compiles_the_cubic_code(interpolation):
    scene = make_scene(field={**VORTEX_FIELD, "interpolation": interpolation})
    text = compiled_text(scene)
    assert mentions(text, "cubic_flow") == (interpolation != "trilinear")
    assert mentions(text, "c111") == (interpolation == "trilinear")
    no_drag = compiled_text(make_scene(drag=False))
    assert not mentions(no_drag, "cubic_flow") and not mentions(no_drag, "flow_field")


def test_a_cubic_field_texture_holds_the_padded_texels(ctx):
    scene = make_scene(field={**VORTEX_FIELD, "interpolation": "bspline"})
    system = ParticleSystem(ctx, scene)
    texture = system.resources["flow_field"]
    nx, ny, nz = scene.field.resolution
    assert texture.size == (nx + 2, ny + 2, nz + 2)
    assert texture.read() == system.features.data["grid_flow"].texels().tobytes()


def test_minimal_scene_allocates_no_field_ground_or_extra_uniforms(ctx):
    system = ParticleSystem(ctx, load_scene(SCENES / "minimal.toml"))
    assert set(system.resources) == {"particles_0", "particles_1", "emitters_0", "emitters_1",
                                     "random_texture", "emitter_table", "gs_tf_counts",
                                     "counters"}  # the capacity's drops: it emits
    assert uniforms(system.particle_program) == {"dt", "gravity"}


def test_scene_without_emitters_has_no_emitter_stream_or_random_texture(ctx):
    system = ParticleSystem(ctx, make_scene(drag=False))
    system.step(FrameInput(np.float32(1 / 60), np.eye(3, dtype=np.float32)))
    # the live count's 12 bytes; no scratch for an emission, nothing to count
    assert set(system.resources) == {"particles_0", "particles_1", "gs_tf_counts"}
    assert system.counters() == {} and system.dropped() == 0


def test_drag_and_ground_allocate_their_textures(ctx, tmp_path):
    system = ParticleSystem(ctx, make_scene(emitters=[FOUNTAIN], collision={
        "kind": "plane", "friction": 0.1, "resilience": 0.5}))
    assert {"flow_field", "random_texture"} <= set(system.resources)
    assert {"flow_field", "inv_tau", "friction", "ground_z"} <= uniforms(system.particle_program)


def test_a_uniform_the_source_never_declares_is_an_error_not_skipped(ctx):
    system = ParticleSystem(ctx, load_scene(SCENES / "minimal.toml"))
    program = system.particle_program
    assert "inv_tau" in program.extra["declared"] and "inv_tau" not in program  # dropped
    write_uniforms(program, {"inv_tau": np.zeros(1, np.float32)})  # skipped, like a feature off
    with pytest.raises(ShaderError, match=r"particles/update.glsl declares no uniform gravty"):
        write_uniforms(program, {"gravty": np.zeros(3, np.float32)})
