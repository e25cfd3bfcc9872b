"""The wall renderer's programs: terrain and helicopter, sky, the light map, dust
billboards, the composite."""

from __future__ import annotations

from enum import IntEnum

from cavesim.core.limits import MAX_PARTICLE_CLASSES
from cavesim.core.scene.model import Scene
from cavesim.gpu.shader_source import ProgramSpec


class Surface(IntEnum):
    """SCENE's shadings, one program each (scene.glsl reads SURFACE and these names as
    defines): a branch on a uniform would cost every pixel all three on software GL."""

    PAINTED = 0  # the vertex colour, lit (the helicopter's body)
    SAND = 1  # the vertex colour with a sand pattern from world xy
    ROTOR = 2  # a translucent disc: blurred blades in the model's xy


SURFACE_DEFINES = {f"SURFACE_{s.name}": int(s) for s in Surface}
SCENE = ProgramSpec("render/scene.glsl", ("vertex", "fragment"), ("SURFACE", *SURFACE_DEFINES))
SKY = ProgramSpec("render/sky.glsl", ("vertex", "fragment"))
DUST = ProgramSpec("render/dust.glsl", ("vertex", "geometry", "fragment"), ("CLASS_COUNT",))
LIGHT_MAP = ProgramSpec("render/light_map.glsl", ("vertex", "fragment"),
                        ("CLASS_COUNT", "NEAREST_PASS"))  # the dust seen from the sun
COMPOSITE = ProgramSpec("render/composite.glsl", ("vertex", "fragment"))
PRESENT = ProgramSpec("render/present.glsl", ("vertex", "fragment"))  # into a window
OVERLAY = ProgramSpec("render/overlay.glsl", ("vertex", "fragment"))  # text over a window


def scene_defines(surface: Surface) -> dict[str, int]:
    return {"SURFACE": int(surface), **SURFACE_DEFINES}


def dust_defines(scene: Scene) -> dict[str, int]:
    return {"CLASS_COUNT": max(1, len(scene.particle_classes))}


def light_map_defines(scene: Scene, nearest: bool) -> dict[str, int]:
    return {**dust_defines(scene), "NEAREST_PASS": int(nearest)}


def render_programs(scene: Scene) -> list[tuple[ProgramSpec, dict[str, int]]]:
    """Every program the renderer builds for a scene, with its defines."""
    return [*((SCENE, scene_defines(surface)) for surface in Surface), (SKY, {}),
            *((LIGHT_MAP, light_map_defines(scene, n)) for n in (True, False)),
            (DUST, dust_defines(scene)), (COMPOSITE, {})]


def render_combinations() -> list[tuple[ProgramSpec, dict[str, int]]]:
    """Every renderer program at the extremes of its defines."""
    return [*((SCENE, scene_defines(surface)) for surface in Surface), (SKY, {}),
            (COMPOSITE, {}), (PRESENT, {}), (OVERLAY, {}),
            *((DUST, {"CLASS_COUNT": count}) for count in (1, MAX_PARTICLE_CLASSES)),
            *((LIGHT_MAP, {"CLASS_COUNT": count, "NEAREST_PASS": nearest})
              for count in (1, MAX_PARTICLE_CLASSES) for nearest in (0, 1))]
