"""One wall's picture of the world: scene, dust as a participating medium, composite.

Pass 1 draws terrain and helicopter, the sky where nothing was drawn and the rotor disc
over them, into a colour and depth target. The light map splats
the live particles along the sun's rays into the dust's optical depth toward the sun
(`light_map.py`). The dust pass turns every live particle into an eye-facing billboard
and adds the optical depth of its soft sphere along each ray into a float target, with
where along the ray it lies (additive blending: no sorting). The composite attenuates the
scene by exp(-optical depth), adds the sunlight and skylight the dust scatters toward the
eye, shadowed through the light map, and tone maps (`medium.py`, render/composite.glsl).
Rendering only reads the particle stream: it never touches what is hashed.
"""

from __future__ import annotations

from dataclasses import dataclass

import moderngl
import numpy as np

from cavesim.core.cave.geometry import Wall
from cavesim.core.cave.projection import gl_matrix, off_axis, recut
from cavesim.core.features.collision import COLLISION, CollisionKind
from cavesim.core.scene_frame import MESH_ROTOR_RADIUS, HelicopterPose
from cavesim.gpu.engine import ParticleSystem
from cavesim.gpu.render import meshes
from cavesim.gpu.render.gltf_model import helicopter_model
from cavesim.gpu.render.light_map import parcel_arrays, shared_light_map
from cavesim.gpu.render.medium import set_parcel_uniforms
from cavesim.gpu.render.programs import (
    COMPOSITE,
    DUST,
    SCENE,
    SKY,
    Surface,
    dust_defines,
    scene_defines,
)

OPEN_GROUND = ((-30.0, -30.0), (30.0, 30.0))  # terrain extent of a scene without a field
DUST_CLIP_NEAR = 1e-4  # m: the dust pass's near plane, well inside the shader's near sphere


@dataclass(frozen=True)
class RenderSettings:
    near: float = 0.05
    far: float = 200.0
    sky: tuple[float, float, float] = (0.62, 0.72, 0.84)  # at the horizon
    sun_direction: tuple[float, float, float] = (0.42, -0.32, 0.85)
    dust_albedo: tuple[float, float, float] = (0.88, 0.78, 0.60)
    dust_ambient: float = 0.35  # the skylight on the dust: this share of the sunlight
    opacity: float = 1.2  # extinction (per metre) per unit of density
    density_per_particle: float = 8.0  # a new parcel's density at its centre (parcel.glsl)
    soft_distance: float = 0.4  # m
    min_radius_pixels: float = 1.5
    sky_zenith: tuple[float, float, float] = (0.27, 0.46, 0.78)
    sun_color: tuple[float, float, float] = (1.0, 0.96, 0.86)
    sun_radius: float = 1.6  # degrees: the drawn disc, larger than the real sun's 0.27
    fog_distance: float = 140.0  # m over which the fog takes 1 - 1/e of a surface's colour
    grid_strength: float = 0.12  # darkening of the terrain's 1 m grid lines
    blade_count: int = 4  # blades of the main rotor
    sun_radiance: float = 3.0  # what sunlit dust of albedo 1 scatters, before exposure
    exposure: float = 1.0  # the tone curve's: display = x / (1 + x), x = exposure * radiance
    ambient_shadow: float = 0.05  # the share of the optical depth to the sun that dims skylight
    eddy_diffusivity: float = 0.05  # m^2/s: how fast a parcel spreads (parcel.glsl)
    max_radius: float = 0.3  # m: ... up to this radius
    fade_time: float = 0.5  # s: a parcel fades out over the end of its life
    light_map_size: int = 512  # texels a side
    layer_depth: float = 0.5  # m: the light map's first layer; the next are 2, 4, 8 times
    forward_scattering: float = 0.6  # g of the phase function's forward lobe (Henyey-
    backward_scattering: float = -0.3  # Greenstein) and of its backward lobe,
    backward_share: float = 0.3  # ... which has this weight
    shadows: bool = True  # the dust shadowed from the sun by the light map
    multiple_scattering: bool = True  # light scattered more than once (composite.glsl)


class WallRenderer:
    """Draws one wall's view of a ParticleSystem's current state."""

    def __init__(self, ctx: moderngl.Context, system: ParticleSystem, wall: Wall,
                 settings: RenderSettings = RenderSettings()) -> None:
        self.ctx, self.system, self.wall, self.settings = ctx, system, wall, settings
        self.size = tuple(wall.resolution)
        self._targets()
        self.scene_programs = [SCENE.build(ctx, scene_defines(surface)) for surface in Surface]
        self.dust_program = DUST.build(ctx, dust_defines(system.scene))
        self.composite_program = COMPOSITE.build(ctx, {})
        self.light_map = shared_light_map(ctx, system, self._sun(), settings)
        self._meshes()
        self._constant_uniforms()

    def _targets(self) -> None:
        ctx, size = self.ctx, self.size
        self.scene_color = ctx.texture(size, 4)
        self.scene_depth = ctx.depth_texture(size)
        self.scene_depth.compare_func = ""  # sampled as plain depth for the soft edges
        self.scene_target = ctx.framebuffer([self.scene_color], self.scene_depth)
        self.dust = ctx.texture(size, 4, dtype="f4")
        self.dust_target = ctx.framebuffer([self.dust])
        self.picture = ctx.texture(size, 4)
        self.picture_target = ctx.framebuffer([self.picture])

    def _meshes(self) -> None:
        def mesh(rows: np.ndarray, surface: int):
            """(vertex array, vertex count, program) of rows shaded as `surface`."""
            program = self.scene_programs[surface]
            vbo = self.ctx.buffer(rows.tobytes())
            vao = self.ctx.vertex_array(program,
                                        [(vbo, meshes.VERTEX_FORMAT, *meshes.VERTEX_NAMES)])
            return vao, len(rows), program

        ground = _ground(self.system)
        self.terrain = mesh(meshes.terrain(*ground), Surface.SAND) if ground else None
        self.sky_program = SKY.build(self.ctx, {})
        self.sky = self.ctx.vertex_array(self.sky_program, [])  # one full-screen triangle
        helicopter = helicopter_model(self.system.scene)
        self.body = mesh(helicopter.body, Surface.PAINTED)
        self.tail_rotor = helicopter.tail_rotor
        self.rotor = mesh(meshes.rotor(MESH_ROTOR_RADIUS), Surface.ROTOR)  # and tail rotor
        self.particles = parcel_arrays(self.ctx, self.dust_program, self.system)
        self.full_screen = self.ctx.vertex_array(self.composite_program, [])

    def _sun(self) -> np.ndarray:
        return np.array(self.settings.sun_direction) / np.linalg.norm(self.settings.sun_direction)

    def _constant_uniforms(self) -> None:
        s = self.settings
        sun = self.sun = self._sun()
        scene = {"sky_horizon": s.sky, "sky_zenith": s.sky_zenith,
                 "sun_direction": tuple(sun), "sun_color": s.sun_color,
                 "sun_cos_radius": float(np.cos(np.radians(s.sun_radius))),
                 "fog_distance": s.fog_distance, "grid_strength": s.grid_strength,
                 "rotor_radius": MESH_ROTOR_RADIUS}
        for program in (*self.scene_programs, self.sky_program):
            for name, value in scene.items():
                if name in program:  # each surface's compiler drops what it does not use
                    program[name].value = value
        dust = self.dust_program
        set_parcel_uniforms(dust, self.system.scene, s)
        dust["near_plane"].value = s.near
        dust["far_plane"].value = s.far
        dust["soft_distance"].value = s.soft_distance
        dust["min_radius_pixels"].value = s.min_radius_pixels
        dust["scene_depth"].value = 0
        composite = self.composite_program
        composite["scene_color"].value = 0
        composite["dust"].value = 1
        composite["dust_albedo"].value = s.dust_albedo
        composite["sun_radiance"].value = s.sun_radiance
        composite["sky_radiance"].value = s.sun_radiance * s.dust_ambient
        composite["exposure"].value = s.exposure
        composite["ambient_shadow"].value = s.ambient_shadow
        composite["forward_scattering"].value = s.forward_scattering
        composite["backward_scattering"].value = s.backward_scattering
        composite["backward_share"].value = s.backward_share
        composite["shadows"].value = s.shadows
        composite["multiple_scattering"].value = s.multiple_scattering
        composite["light_toward"].value = tuple(sun)

    def render(self, eye, helicopter: HelicopterPose | None) -> np.ndarray:
        """The wall's picture from `eye` (room = world metres): (height, width, 3) uint8."""
        self.draw(eye, helicopter)
        pixels = self.picture.read()
        width, height = self.size
        return np.frombuffer(pixels, np.uint8).reshape(height, width, 4)[::-1, :, :3].copy()

    def draw(self, eye, helicopter: HelicopterPose | None) -> None:
        """Draw the wall's picture from `eye` into `self.picture` (the one drawing path of
        the PNGs and of the window, `cavesim.gpu.window`)."""
        projection, view = off_axis(self.wall, np.asarray(eye, float), self.settings.near,
                                    self.settings.far)
        ctx = self.ctx
        try:
            self._scene_pass(projection, view, helicopter)
            self._dust_pass(projection, view)
            self._composite_pass(projection, view, eye)
        finally:
            ctx.disable(moderngl.BLEND | moderngl.DEPTH_TEST)
            ctx.blend_func = moderngl.DEFAULT_BLENDING
            ctx.extra["framebuffer"].use()  # the engine's transform feedback needs it bound

    def _scene_pass(self, projection, view, helicopter) -> None:
        """Opaque terrain and body, then the sky where nothing was drawn, then the rotor
        discs blended over both (they write no depth: dust behind them shows through)."""
        ctx = self.ctx
        self.scene_target.use()
        self.scene_target.clear(depth=1.0)
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.disable(moderngl.BLEND)
        eye = np.linalg.inv(view)[:3, 3]
        for program in self.scene_programs:
            program["view"].write(gl_matrix(view))
            program["projection"].write(gl_matrix(projection))
            program["eye"].value = tuple(eye)

        def draw(mesh, model) -> None:
            vao, count, program = mesh
            program["model"].write(gl_matrix(model))
            vao.render(moderngl.TRIANGLES, vertices=count)

        if self.terrain:
            draw(self.terrain, np.eye(4))
        if helicopter is not None:
            draw(self.body, helicopter.model())
        ctx.depth_func = "<="  # the sky lies on the far plane, where the depth is clear
        self.sky_program["world_from_clip"].write(gl_matrix(np.linalg.inv(projection @ view)))
        self.sky_program["eye"].value = tuple(eye)
        self.sky.render(moderngl.TRIANGLES, vertices=3)
        ctx.depth_func = "<"
        if helicopter is not None:
            ctx.enable(moderngl.BLEND)
            ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
            self.scene_target.depth_mask = False
            discs = [(helicopter.rotor_model(), self.settings.blade_count)]
            if self.tail_rotor is not None:
                discs.append((helicopter.tail_rotor_model(self.tail_rotor.hub,
                                                          self.tail_rotor.radius),
                              meshes.TAIL_ROTOR_BLADES))
            try:
                for model, blades in discs:
                    self.rotor[2]["model_from_world"].write(gl_matrix(np.linalg.inv(model)))
                    self.rotor[2]["blade_count"].value = float(blades)
                    draw(self.rotor, model)
            finally:
                self.scene_target.depth_mask = True
                ctx.disable(moderngl.BLEND)
                ctx.blend_func = moderngl.DEFAULT_BLENDING

    def _dust_pass(self, projection, view) -> None:
        ctx = self.ctx
        live = self.system.live_count
        if live:
            self.light_map.draw()  # the composite lights the dust from it
        self.dust_target.use()
        self.dust_target.clear(0.0, 0.0, 0.0, 0.0)
        if not live:
            return
        ctx.disable(moderngl.DEPTH_TEST)
        ctx.enable(moderngl.BLEND)
        ctx.blend_func = moderngl.ONE, moderngl.ONE
        self.dust_program["view"].write(gl_matrix(view))
        self.dust_program["projection"].write(
            gl_matrix(recut(projection, DUST_CLIP_NEAR, self.settings.far)))
        # P[1][1] = 2n / (t - b): pixels per unit of y/z slope is P[1][1] * height / 2
        self.dust_program["pixels_per_unit_slope"].value = projection[1, 1] * self.size[1] / 2
        self.scene_depth.use(0)
        self.particles[self.system.front_particle_buffer_name].render(moderngl.POINTS,
                                                                      vertices=live)

    def _composite_pass(self, projection, view, eye) -> None:
        self.ctx.disable(moderngl.BLEND | moderngl.DEPTH_TEST)
        self.picture_target.use()
        program = self.composite_program
        program["world_from_clip"].write(gl_matrix(np.linalg.inv(projection @ view)))
        program["eye"].value = tuple(np.asarray(eye, float))
        self.light_map.use(program, 2, 3)
        self.scene_color.use(0)
        self.dust.use(1)
        self.full_screen.render(moderngl.TRIANGLES, vertices=3)

    def release(self) -> None:
        self.light_map.release()
        for target in (self.scene_target, self.dust_target, self.picture_target):
            target.release()
        for texture in (self.scene_color, self.scene_depth, self.dust, self.picture):
            texture.release()


def _ground(system: ParticleSystem):
    """(box_min, box_max, plane height or HeightGrid) of the scene's ground, or None: the
    ground the particles collide with, as the engine loaded it."""
    scene, collision = system.scene, system.scene.collision
    if collision is None:
        return None
    if collision.kind is CollisionKind.HEIGHTFIELD:
        grid = system.features.data[COLLISION.name]
        return grid.box_min, grid.box_max, grid
    if scene.field is not None:
        return scene.field.box_min[:2], scene.field.box_max[:2], collision.height
    return *OPEN_GROUND, collision.height
