"""Gridded data on the CPU: the flow fields the GPU samples, and the ground's heights.

A scene's [field] becomes a `FieldSeries` (`grid.py`: one `FieldGrid` a snapshot) built from
an analytic model (`analytic.py`), a file (`flow_files.py`: NetCDF, VTK image data; an .npz
in `grid.py`), or a rotating flow's snapshots; `interpolation.py` holds the cubic
interpolants and their texels, `snapshot_time.py` where a frame falls between a series'
snapshots, `regular_grid.py` what every regular grid shares (cells, boxes, .npz arrays), and
`heights.py` a height field's ground.
"""
