"""The concentration-field error: how much of the cloud a run puts in the wrong place.

A CAVE user sees the cloud, not one particle: two runs whose particles swap places show
the same cloud. So the particles' final positions are deposited on a grid of CLOUD_CELL
cubes, cloud-in-cell (each particle's unit mass shared among the 8 nodes around it by
trilinear weights: the density moves continuously with the particles, and no bin edge
turns a tiny error into a whole particle), and two clouds are compared by the fraction
of mass misplaced: half the L1 distance of their normalized densities, 0 for the same
cloud and 1 for disjoint ones. The grid spans the reference cloud; a run's mass that
leaves it is counted as misplaced.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

CLOUD_CELL = 1.0  # m: about the smallest puff a viewer picks out of a cloud tens of m wide
MARGIN_CELLS = 2  # of grid around the reference cloud


@dataclass(frozen=True)
class CloudGrid:
    origin: np.ndarray  # (3,) m, the first node
    shape: tuple[int, int, int]  # nodes per axis
    cell: float = CLOUD_CELL

    @classmethod
    def around(cls, positions: np.ndarray, cell: float = CLOUD_CELL) -> CloudGrid:
        """The grid of `cell` cubes over `positions` with MARGIN_CELLS to spare each side."""
        low = np.floor(positions.min(axis=0) / cell) - MARGIN_CELLS
        high = np.ceil(positions.max(axis=0) / cell) + MARGIN_CELLS
        shape = tuple(int(n) for n in high - low + 1)
        return cls(low * cell, shape, cell)

    def density(self, positions: np.ndarray) -> np.ndarray:
        """Cloud-in-cell mass per node, each particle 1 / len(positions); particles whose
        cell is not inside the grid deposit nothing."""
        x = (positions - self.origin) / self.cell
        base = np.floor(x).astype(np.int64)
        frac = x - base
        inside = np.all((base >= 0) & (base < np.array(self.shape) - 1), axis=1)
        base, frac = base[inside], frac[inside]
        grid = np.zeros(self.shape)
        for corner in np.ndindex(2, 2, 2):
            weight = np.prod(np.where(corner, frac, 1.0 - frac), axis=1)
            np.add.at(grid, tuple((base + corner).T), weight)
        return grid / len(positions)


def misplaced_fraction(grid: CloudGrid, positions: np.ndarray,
                       reference_density: np.ndarray) -> float:
    """Half the L1 distance between the cloud of `positions` and the reference cloud, the
    mass outside the grid counted as misplaced: 0 (the same cloud) to 1 (disjoint)."""
    density = grid.density(positions)
    outside = 1.0 - density.sum()
    return 0.5 * float(np.abs(density - reference_density).sum() + max(outside, 0.0))
