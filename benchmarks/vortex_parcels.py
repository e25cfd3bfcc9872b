"""OceanParcels 4's runs of the vortex case: its RK4 kernel (AdvectionRK4_3D, trilinear
XLinear interpolation of U, V and W) on the same grid, given as an xarray dataset of nodes
(an Arakawa A grid, `parcels.convert.copernicusmarine_to_sgrid`), with float32 or float64
particles. Each step is one `ParticleSet.execute` of one dt, its clock stopped when it
returns (Parcels computes with numpy: nothing is left running). Import it only where
parcels is installed."""

from __future__ import annotations

import numpy as np
import parcels
import xarray as xr
from parcels.convert import copernicusmarine_to_sgrid

from benchmarks.vortex_case import DT, NODES, STEPS, Run, position_errors, time_steps
from cavesim.tools.numerics.solid_body import solid_body_grid

SPATIAL = ("x", "y", "z", "dx", "dy", "dz")  # a particle's variables of its position's dtype


def vortex_fieldset() -> parcels.FieldSet:
    """cavesim's NODES³ grid of the vortex, node for node. Parcels calls z depth (positive
    down), which only flips W's sign: W is 0 here."""
    grid = solid_body_grid(NODES)
    axes = {name: np.linspace(lo, hi, NODES)
            for name, lo, hi in zip(("lon", "lat", "depth"), grid.box_min, grid.box_max,
                                    strict=True)}
    coords = {name: (name, values, {"axis": axis})
              for (name, values), axis in zip(axes.items(), "XYZ", strict=True)}
    fields = {name: xr.DataArray(grid.velocity[..., i].copy(), dims=("depth", "lat", "lon"),
                                 coords=coords)
              for i, name in enumerate("UVW")}
    return parcels.FieldSet.from_sgrid_conventions(copernicusmarine_to_sgrid(fields=fields),
                                                   mesh="flat")


def particle_class(dtype: type[np.floating]) -> parcels.ParticleClass:
    """Parcels' default particle with its position in `dtype` (float32: parcels.Particle)."""
    return parcels.ParticleClass([
        parcels.Variable(v.name, dtype=dtype, initial=v.initial, to_write=v.to_write,
                         attrs=v.attrs) if v.name in SPATIAL else v
        for v in parcels.Particle.variables])


def parcels_run(fieldset: parcels.FieldSet, start: np.ndarray,
                dtype: type[np.floating]) -> Run:
    particles = parcels.ParticleSet(fieldset, particle_class(dtype), x=start[:, 0],
                                    y=start[:, 1], z=start[:, 2])

    def step() -> None:
        particles.execute(parcels.kernels.AdvectionRK4_3D, dt=DT, runtime=DT,
                          verbose_progress=False)

    step_s, total_s = time_steps(step)
    end = np.stack([particles.x, particles.y, particles.z], axis=1).astype(np.float64)
    rms, worst = position_errors(start, end, STEPS * DT)  # Parcels' dt is float64
    return Run(f"Parcels {parcels.__version__} {np.dtype(dtype).name}", len(start), step_s,
               total_s, rms, worst)
