"""The light map: the dust's optical depth seen from the sun (a deep opacity map), drawn
each frame before the dust pass, which reads it to shadow every particle's sunlight.

It covers the scene's box (the field's, or open ground's), fitted orthographically along
the sun's rays: fixed in the world, so every wall of every node draws the same map from the
same particles. The walls that draw one system share one map (`shared_light_map`), drawn
once per state of the particles, whatever the walls and eyes that read it. Two passes over
the particles: where the dust begins per texel, then the optical depth in layers behind
that (render/light_map.glsl, include/sunlight.glsl).

A pass over a particle costs about as much as drawing it on a wall, so the map is drawn
from every k-th particle of the stream (k fixed by the scene's capacity, so a node's map
does not change its sampling as the live count moves), each splat k times as deep and
k^(1/3) times as wide: the same optical depth, estimated from fewer, smoother kernels.
"""

from __future__ import annotations

import moderngl
import numpy as np

from cavesim.core.cave.projection import gl_matrix
from cavesim.gpu.engine import ParticleSystem
from cavesim.gpu.render.medium import MediumSettings, set_parcel_uniforms
from cavesim.gpu.render.programs import LIGHT_MAP, light_map_defines

PARCEL_FIELDS = (("4u", "in_a"), ("8x", None), ("2u", "in_age"), ("2u", "in_c"))  # velocity
# skipped: position, age, lifetime and class, of a 40-byte record
RECORD_BYTES = 40
MAP_PARTICLES = 16384  # at most this many particles drawn into the map ...
MAX_STRIDE = 2048 // RECORD_BYTES  # ... while a vertex stride stays within GL 4.4's least
# GL_MAX_VERTEX_ATTRIB_STRIDE (a larger pool draws more of its particles)
OPEN_BOX = ((-30.0, -30.0, -5.0), (30.0, 30.0, 25.0))  # m: a scene without a field's box
FAR = 1e30  # where no dust begins


def light_box(system: ParticleSystem) -> tuple[np.ndarray, np.ndarray]:
    """The world box the light map covers: the field's box, or OPEN_BOX."""
    field = system.scene.field
    if field is not None:
        return np.asarray(field.box_min, float), np.asarray(field.box_max, float)
    return np.asarray(OPEN_BOX[0]), np.asarray(OPEN_BOX[1])


def fit(sun: np.ndarray, box_min, box_max) -> tuple[np.ndarray, float]:
    """(light_from_world, metres per unit of map clip space) for an orthographic view along
    the rays toward -`sun` that holds the box: x, y in [-1, 1], z in metres from the box's
    corner nearest the sun. Square texels."""
    depth_axis = -np.asarray(sun, float) / np.linalg.norm(sun)
    helper = np.array([0.0, 0.0, 1.0]) if abs(depth_axis[2]) < 0.9 else np.array([1.0, 0, 0])
    u = np.cross(helper, depth_axis)
    u /= np.linalg.norm(u)
    v = np.cross(depth_axis, u)
    corners = np.array([[x, y, z] for x in (box_min[0], box_max[0])
                        for y in (box_min[1], box_max[1]) for z in (box_min[2], box_max[2])])
    axes = np.stack([u, v, depth_axis])
    projected = corners @ axes.T
    low, high = projected.min(axis=0), projected.max(axis=0)
    centre, half = (low + high) / 2, max(high[0] - low[0], high[1] - low[1]) / 2
    matrix = np.eye(4)
    matrix[0, :3], matrix[0, 3] = u / half, -centre[0] / half
    matrix[1, :3], matrix[1, 3] = v / half, -centre[1] / half
    matrix[2, :3], matrix[2, 3] = depth_axis, -low[2]
    return matrix, half


_SHARED: dict[tuple, LightMap] = {}  # by system (its id, held alive by the map), sun, settings


def shared_light_map(ctx: moderngl.Context, system: ParticleSystem, sun: np.ndarray,
                     settings: MediumSettings) -> LightMap:
    """The one map of `system` lit from `sun` under `settings`, for every renderer that
    asks: each call takes a share, and `LightMap.release` gives it back (the last frees it)."""
    key = (id(system), tuple(np.asarray(sun, float)), settings)
    light_map = _SHARED.get(key)
    if light_map is None:
        light_map = _SHARED[key] = LightMap(ctx, system, sun, settings)
        light_map.key = key
    light_map.shares += 1
    return light_map


class LightMap:
    """The optical depth toward the sun of a ParticleSystem's current dust."""

    def __init__(self, ctx: moderngl.Context, system: ParticleSystem, sun: np.ndarray,
                 settings: MediumSettings) -> None:
        self.ctx, self.system = ctx, system
        self.key: tuple | None = None  # in _SHARED, when shared
        self.shares = 0
        self.drawn_generation: int | None = None  # the system's state the map holds
        size = (settings.light_map_size,) * 2
        self.light_from_world, half = fit(sun, *light_box(system))
        self.nearest = ctx.texture(size, 1, dtype="f4")
        self.layers = ctx.texture(size, 4, dtype="f4")
        for texture in (self.nearest, self.layers):
            texture.filter = moderngl.NEAREST, moderngl.NEAREST
            texture.repeat_x = texture.repeat_y = False
        self.nearest_target = ctx.framebuffer([self.nearest])
        self.layers_target = ctx.framebuffer([self.layers])
        self.programs = [LIGHT_MAP.build(ctx, light_map_defines(system.scene, nearest))
                         for nearest in (True, False)]
        self.stride = min(max(1, -(-system.scene.capacity // MAP_PARTICLES)), MAX_STRIDE)
        for program in self.programs:
            set_parcel_uniforms(program, system.scene, settings)
            program["sample_stride"].value = self.stride
            program["light_from_world"].write(gl_matrix(self.light_from_world))
            program["texels_per_metre"].value = size[0] / (2 * half)
            program["min_size_texels"].value = settings.min_radius_pixels * 2
        self.programs[1]["light_nearest"].value = 0
        self.programs[1]["layer_depth"].value = settings.layer_depth
        self.layer_depth = settings.layer_depth
        self.particles = [parcel_arrays(ctx, program, system, self.stride)
                          for program in self.programs]

    def use(self, program: moderngl.Program, nearest_unit: int, layers_unit: int) -> None:
        """Bind the map for a program that includes sunlight.glsl."""
        program["light_from_world"].write(gl_matrix(self.light_from_world))
        program["light_nearest"].value = nearest_unit
        program["light_layers"].value = layers_unit
        program["layer_depth"].value = self.layer_depth
        self.nearest.use(nearest_unit)
        self.layers.use(layers_unit)

    def draw(self) -> None:
        """Splat the live particles: nearest dust per texel, then the layers behind it
        (once per state of the system)."""
        if self.drawn_generation != self.system.generation:
            self.splat()

    def splat(self) -> None:
        """Splat the live particles now, whatever the map holds."""
        self.drawn_generation = self.system.generation
        ctx, live = self.ctx, self.system.live_count
        self.nearest_target.clear(FAR, 0.0, 0.0, 0.0)
        self.layers_target.clear(0.0, 0.0, 0.0, 0.0)
        if not live:
            return
        count = (live - 1) // self.stride + 1
        front = self.system.front_particle_buffer_name
        ctx.disable(moderngl.DEPTH_TEST)
        ctx.enable(moderngl.BLEND | moderngl.PROGRAM_POINT_SIZE)
        ctx.blend_func = moderngl.ONE, moderngl.ONE
        try:
            self.nearest_target.use()
            ctx.blend_equation = moderngl.MIN
            self.particles[0][front].render(moderngl.POINTS, vertices=count)
            self.layers_target.use()
            ctx.blend_equation = moderngl.FUNC_ADD
            self.nearest.use(0)
            self.particles[1][front].render(moderngl.POINTS, vertices=count)
        finally:
            ctx.blend_equation = moderngl.FUNC_ADD
            ctx.disable(moderngl.PROGRAM_POINT_SIZE)

    def release(self) -> None:
        """Give back a share; the last frees the map."""
        self.shares -= 1
        if self.shares > 0:
            return
        if self.key is not None:
            del _SHARED[self.key]
        for target in (self.nearest_target, self.layers_target):
            target.release()
        for texture in (self.nearest, self.layers):
            texture.release()


def parcel_arrays(ctx: moderngl.Context, program: moderngl.Program, system: ParticleSystem,
                  stride: int = 1) -> dict[str, moderngl.VertexArray]:
    """A vertex array per particle buffer that feeds `program` every `stride`-th record's
    PARCEL_FIELDS; a field the compiler dropped (one class, no fading in that pass) is
    skipped as padding, as the layout must match the program's inputs."""
    layout, names = [], []
    for words, name in PARCEL_FIELDS:
        if name is not None and name in program:
            layout.append(words)
            names.append(name)
        else:
            layout.append(f"{4 * int(words[:-1])}x" if words.endswith("u") else words)
    if stride > 1:
        layout.append(f"{RECORD_BYTES * (stride - 1)}x")
    return {name: ctx.vertex_array(program, [(buffer, " ".join(layout), *names)])
            for name, buffer in system.resources.items() if name.startswith("particles_")}
