"""A flow file in world coordinates 5 km from the world's origin, as NetCDF, VTK image data
and .npz, and a scene of tracers in it with `[simulation] origin` at the grid's centre.

The flow is linear, so trilinear sampling is exact and every node tells its place:
u = 2 + z/64, v = x/16, w = 0 (m/s, x, y, z metres from the centre OUT): 2 m/s along x at
the centre. Its tracers move in closed form (`expected_positions`), which RK4 (and any
second-order method) steps exactly. A grid read at its world box while the scene runs near
zero gives them 0 m/s (out_of_domain = "zero") or the boundary's flow ("clamp").
"""

from __future__ import annotations

import base64
from pathlib import Path

import numpy as np
import xarray as xr
from scenes import SMOKE

from cavesim.core.fields.grid import FieldGrid, save_field
from cavesim.core.records import PARTICLE_DTYPE

OUT = (5000.0, -3000.0, 100.0)  # m: the grid's centre in the world, and the scene's origin
NODES = np.arange(-8.0, 9.0, 4.0)  # m from the centre: 5 nodes 4 m apart on each axis
FORMATS = (".nc", ".vti", ".npz")
WORLD_BOX = (tuple(o + NODES[0] for o in OUT), tuple(o + NODES[-1] for o in OUT))
LOCAL_BOX = ((NODES[0],) * 3, (NODES[-1],) * 3)


def shear(x, y, z) -> np.ndarray:
    """The flow (..., 3) at points x, y, z metres from the centre."""
    x, y, z = np.broadcast_arrays(x, y, z)
    return np.stack([2.0 + z / 64, x / 16, np.zeros_like(x)], axis=-1)


def world_velocity() -> np.ndarray:
    """The flow at the nodes, (nz, ny, nx, 3) float32 (exact: the values are dyadic)."""
    return shear(NODES[None, None, :], NODES[None, :, None], NODES[:, None, None]).astype(
        np.float32)


def write_far_field(folder: Path, suffix: str) -> Path:
    """The flow in a `suffix` file in `folder`, its coordinates and box the world's."""
    path = Path(folder) / f"far{suffix}"
    velocity = world_velocity()
    if suffix == ".npz":
        save_field(path, FieldGrid(velocity, *WORLD_BOX))
    elif suffix == ".nc":
        data = {name: (("z", "y", "x"), velocity[..., i], {"units": "m/s"})
                for i, name in enumerate("uvw")}
        coords = {name: (name, o + NODES, {"units": "m"})
                  for name, o in zip("xyz", OUT, strict=True)}
        xr.Dataset(data, coords=coords).to_netcdf(path, engine="netcdf4")
    else:
        extent = " ".join(f"0 {len(NODES) - 1}" for _ in range(3))
        encoded = base64.b64encode(np.array(velocity.nbytes, "<u4").tobytes()
                                   + velocity.astype("<f4").tobytes()).decode()
        path.write_text(
            '<VTKFile type="ImageData" byte_order="LittleEndian" header_type="UInt32">'
            f'<ImageData WholeExtent="{extent}" Origin="{" ".join(map(str, WORLD_BOX[0]))}" '
            f'Spacing="4 4 4"><Piece Extent="{extent}"><PointData Vectors="velocity">'
            '<DataArray type="Float32" Name="velocity" NumberOfComponents="3" '
            f'format="binary">{encoded}</DataArray></PointData></Piece></ImageData></VTKFile>')
    return path


def far_scene(path: Path, origin=OUT, arithmetic: str = "native", engine: str = "gs_tf",
              out_of_domain: str = "zero", **field) -> dict:
    """A scene dict of tracers (class 0) in the flow of the file at `path`, stepped by RK4,
    its origin at `origin`."""
    return {
        "simulation": {"capacity": 256, "seed": 5, "random_texture_size": 64,
                       "engine": engine, "arithmetic": arithmetic, "tracer_method": "rk4",
                       "origin": list(origin)},
        "particle_class": [SMOKE],
        "forces": {"drag": {}},
        "field": {"kind": "file", "file": str(path), "out_of_domain": out_of_domain, **field},
    }


def tracers(count: int, seed: int = 0) -> np.ndarray:
    """`count` tracers that live forever, within 4 m of the centre (positions relative to
    it: the scene's origin)."""
    records = np.zeros(count, PARTICLE_DTYPE)
    records["pos"] = np.random.default_rng(seed).uniform(-4.0, 4.0, (count, 3))
    records["lifetime"] = 1e6
    return records


def expected_positions(start: np.ndarray, t: float) -> np.ndarray:
    """Where tracers from `start` (N, 3), metres from the centre, are after t seconds:
    z stays, x moves at 2 + z/64, y at x/16."""
    x, y, z = (start[:, a].astype(np.float64) for a in range(3))
    u = 2.0 + z / 64
    return np.stack([x + u * t, y + x * t / 16 + u * t * t / 32, z], axis=1)
