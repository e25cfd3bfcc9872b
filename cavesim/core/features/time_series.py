"""A flow that changes in time: a grid given as snapshots (a NetCDF's or an .npz's time
axis, or the `rotating` kind's), stacked along z in one 3D texture. Each frame the master
says where the frame's stages fall between them (cavesim/core/fields/snapshot_time.py:
a pair and a weight per stage, sent as the frame's last scene parameters), and the flow at
a stage mixes its pair linearly in time (shaders/include/field.glsl, FIELD_TIME_SERIES;
the twins: `grid_flow.series_flow`).
"""

from __future__ import annotations

import numpy as np

from cavesim.core.features.feature import Feature
from cavesim.core.features.grid_flow import GRID
from cavesim.core.features.rules import Rule
from cavesim.core.fields.snapshot_time import FIRST_SNAPSHOT


class TimeSeries(Feature):
    name = "time_series"
    keys = ("field.time_units",)  # and the time axis of a file, or of `rotating`'s params
    defines = {"FIELD_TIME_SERIES": (0, 1)}
    rules = (Rule("FIELD_TIME_SERIES", GRID, "field", "only a grid is a time series"),)

    def present(self, scene):
        return scene.gridded_flow and scene.field.times is not None

    def uniforms(self, scene, data):
        return {"field_snapshots": np.int32(len(scene.field.times))}

    def frame_uniforms(self, scene, data, state):
        field_time = FIRST_SNAPSHOT if state is None else state.field_time
        return {"field_pair": np.array(field_time.pairs, dtype=np.int32),
                "field_weight": np.array(field_time.weights, dtype=np.float32)}


TIME_SERIES = TimeSeries()
