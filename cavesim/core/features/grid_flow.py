"""A flow given on a grid: every [field] kind but the rotor's (uniform, vortex, downwash,
rotating, file). The loader reads it (`cavesim.core.fields`), the GPU samples it as a 3D
texture (shaders/include/field.glsl) by hand (`sampling = "manual"`: texelFetch, trilinear
or cubic, the same bits on every GPU in portable arithmetic) or by the texture unit
("hardware": faster, vendor-dependent weights); outside its box the flow is the nearest
boundary node's ("clamp") or still air ("zero"). A time series of grids is `time_series`.
The twins sample the same grid: `sample_field` (float64) and the portable `flow_at`.
"""

from __future__ import annotations

import numpy as np

from cavesim.core.features.feature import Feature, Texture
from cavesim.core.features.rules import Rule
from cavesim.core.fields.grid import FieldSeries, build_series, outside_box, sample_field
from cavesim.core.fields.regular_grid import mix
from cavesim.core.fields.snapshot_time import FieldTime, places_in_step
from cavesim.core.portable import field as portable_field
from cavesim.core.portable.arithmetic import f_mix
from cavesim.core.scene.model import Arithmetic, FieldInterpolation, FieldSampling, OutOfDomain

GRID = "HAS_DRAG && !FIELD_IS_ROTOR"  # a scene's flow is a grid
# ARITHMETIC's value in native arithmetic (arithmetic.glsl names it after the rules' checks)
NATIVE = list(Arithmetic).index(Arithmetic.NATIVE)


def ids(prefix: str, table) -> dict[str, int]:
    """The GLSL ids of an enum's members, in its order: PREFIX_NAME."""
    return {f"{prefix}_{member.name}": number for number, member in enumerate(table)}


class GridFlow(Feature):
    name = "grid_flow"
    keys = ("field", "field.sampling", "field.interpolation", "field.out_of_domain")
    ids = {**ids("OUT_OF_DOMAIN", OutOfDomain), **ids("SAMPLING", FieldSampling),
           **ids("INTERPOLATION", FieldInterpolation)}
    defines = {"FIELD_OUT_OF_DOMAIN": tuple(range(len(OutOfDomain))),
               "FIELD_SAMPLING": tuple(range(len(FieldSampling))),
               "FIELD_INTERPOLATION": tuple(range(len(FieldInterpolation)))}
    rules = (
        Rule("FIELD_SAMPLING == SAMPLING_HARDWARE", f"ARITHMETIC == {NATIVE}",
             "field.sampling", 'must be "manual" with simulation.arithmetic = "portable": the '
             "texture unit's filter weights differ from vendor to vendor"),
        Rule("FIELD_INTERPOLATION != INTERPOLATION_TRILINEAR",
             f"{GRID} && FIELD_SAMPLING == SAMPLING_MANUAL", "field.interpolation",
             'must be "trilinear" with sampling = "hardware": the texture unit filters '
             'trilinearly; use sampling = "manual"'),
        Rule("FIELD_SAMPLING != SAMPLING_MANUAL", GRID, "field.sampling",
             "only a grid is sampled"),
        Rule("FIELD_OUT_OF_DOMAIN != OUT_OF_DOMAIN_CLAMP", GRID, "field.out_of_domain",
             "only a grid has a box to leave"),
    )
    include = "field.glsl"

    def present(self, scene):
        return scene.gridded_flow

    def where(self, scene, key):
        return key, getattr(scene.field, key.removeprefix("field.")).value

    def define_values(self, scene):
        field = scene.field
        return {"FIELD_OUT_OF_DOMAIN": list(OutOfDomain).index(field.out_of_domain),
                "FIELD_SAMPLING": list(FieldSampling).index(field.sampling),
                "FIELD_INTERPOLATION": list(FieldInterpolation).index(field.interpolation)}

    def load(self, scene, random) -> FieldSeries:
        return build_series(scene.field)

    def textures(self, scene, data):
        hardware = scene.field.sampling is FieldSampling.HARDWARE
        return (Texture("flow_field", data.texels(), linear=hardware,
                        what=f"the field's texture ({len(data.snapshots)} snapshot(s) "
                             "stacked along z)", fewer="snapshots or nodes"),)

    def uniforms(self, scene, data):
        return {"field_box_min": np.array(data.first.box_min, dtype=np.float32),
                "field_index_scale": data.first.index_scale}

    def force_terms(self, scene, data, kernels, class_id, state):
        out_of_domain = scene.field.out_of_domain

        def flow(p, stage):
            return series_flow(data, p, out_of_domain, state.field_time, stage, kernels)

        return {"flow": flow}


GRID_FLOW = GridFlow()


def series_flow(series: FieldSeries, p: np.ndarray, out_of_domain: OutOfDomain,
                field_time: FieldTime, stage: int | np.ndarray | None, kernels) -> np.ndarray:
    """u(p) at a stage of the step, or at each point's fraction of it: flow_at and
    flow_in_step of shaders/include/field.glsl (a steady field's one snapshot, else the pair
    there mixed by its weight), in the arithmetic of `kernels`."""
    if kernels.portable:
        def sample(grid, points):
            return portable_field.flow_at(grid, points, out_of_domain)
        blend = f_mix
    else:
        def sample(grid, points):
            return sample_field(grid, points, out_of_domain, dtype=kernels.dtype)
        blend = mix
    if series.steady:
        return sample(series.first, p)
    if stage is None:
        raise ValueError("a time series' flow is known at a step's start, middle and end")
    if isinstance(stage, np.ndarray):  # each point's fraction of the step
        pairs, weights = places_in_step(field_time, stage, len(series.snapshots),
                                        kernels.operations)
    else:
        pairs = np.full(len(p), field_time.pairs[stage])
        weights = np.full(len(p), field_time.weights[stage], dtype=kernels.dtype)
    flow = np.empty_like(p)
    for pair in np.unique(pairs):
        rows = pairs == pair
        first, second = series.snapshots[pair], series.snapshots[pair + 1]
        flow[rows] = blend(sample(first, p[rows]), sample(second, p[rows]),
                           weights[rows][:, None])
    return flow


def outside(series: FieldSeries, p: np.ndarray, kernels) -> np.ndarray:
    """Whether each point (N, 3) lies outside the grid's closed box, as the particle pass
    sees it (field.glsl's `outside_field`), in the arithmetic of `kernels`."""
    if kernels.portable:
        return portable_field.outside_field(series.first, p)
    return outside_box(series.first, p, dtype=kernels.dtype)
