"""The world-fixed archive of a run's maps: the last FOG and baseline value of every cell.

The mapper's grids follow the robot and scroll by whole cells, so a run is scored on a
:class:`WorldArchive`: a world-fixed lattice of the mapper's cells that keeps, for every cell
that was ever inside the map, the last FOG and averaging-baseline value it had there. Arrays are
indexed ``[ix, iy]`` over the lattice, heights in metres in the world frame, NaN = none.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from fogsim.errors import FogsimError
from mapper import CellType


class WorldArchive:
    """World-fixed lattice of the mapper's cells: the last FOG / baseline value of each cell.

    The lattice is anchored at the first grid's cell centres; the mapper scrolls by whole cells,
    so every later grid lies on it. Storage grows as the robot walks (bounding box of all grids).
    """

    def __init__(self, cell_m: float) -> None:
        self.cell_m = float(cell_m)
        self._anchor_xy: NDArray[np.float64] | None = None
        self._lo = np.zeros(2, dtype=np.int64)  # lattice index of array cell [0, 0]
        self.fog_types = np.zeros((0, 0), dtype=np.int8)
        self.fog_heights_m = np.zeros((0, 0))
        self.baseline_heights_m = np.zeros((0, 0))
        self.visited = np.zeros((0, 0), dtype=bool)

    def _anchor(self) -> NDArray[np.float64]:
        """World centre [m] of lattice cell (0, 0): the first stored grid's first cell."""
        if self._anchor_xy is None:
            raise FogsimError("the world archive is empty: store a map before asking for cells")
        return self._anchor_xy

    def lattice_index(self, points_xy: NDArray[np.floating]) -> NDArray[np.int64]:
        """Lattice index (…, 2) of world points (…, 2) [m] (nearest cell centre)."""
        return np.rint((np.asarray(points_xy) - self._anchor()) / self.cell_m).astype(np.int64)

    def _grow(self, lo: NDArray[np.int64], hi: NDArray[np.int64]) -> None:
        new_lo = np.minimum(self._lo, lo) if self.visited.size else lo
        old_hi = self._lo + np.array(self.visited.shape)
        new_hi = np.maximum(old_hi, hi) if self.visited.size else hi
        if (
            self.visited.size
            and np.array_equal(new_lo, self._lo)
            and np.array_equal(new_hi, old_hi)
        ):
            return
        shape = tuple(int(v) for v in new_hi - new_lo)
        before = self._lo - new_lo
        arrays = []
        for old, fill in (
            (self.fog_types, CellType.UNKNOWN),
            (self.fog_heights_m, np.nan),
            (self.baseline_heights_m, np.nan),
            (self.visited, False),
        ):
            grown = np.full(shape, fill, dtype=old.dtype)
            if old.size:
                grown[
                    before[0] : before[0] + old.shape[0], before[1] : before[1] + old.shape[1]
                ] = old
            arrays.append(grown)
        self.fog_types, self.fog_heights_m, self.baseline_heights_m, self.visited = arrays
        self._lo = new_lo

    def store(
        self,
        cell_centers_xy: NDArray[np.floating],
        fog_types: NDArray[np.integer],
        fog_heights_m: NDArray[np.floating],
        baseline_heights_m: NDArray[np.floating],
    ) -> None:
        """Copy the current maps (nx, ny) with their cell centres (nx, ny, 2) into the archive."""
        centers = np.asarray(cell_centers_xy, dtype=np.float64)
        if self._anchor_xy is None:
            self._anchor_xy = centers[0, 0].copy()
        corner = self.lattice_index(centers[0, 0])
        nx, ny = centers.shape[:2]
        self._grow(corner, corner + np.array([nx, ny]))
        ox, oy = (int(v) for v in corner - self._lo)
        sl = (slice(ox, ox + nx), slice(oy, oy + ny))
        self.fog_types[sl] = fog_types
        self.fog_heights_m[sl] = fog_heights_m
        self.baseline_heights_m[sl] = baseline_heights_m
        self.visited[sl] = True

    def cell_centers_xy(self) -> NDArray[np.float64]:
        """(nx, ny, 2) world centres [m] of the archive's cells."""
        anchor_xy = self._anchor()
        ix = np.arange(self.visited.shape[0]) + self._lo[0]
        iy = np.arange(self.visited.shape[1]) + self._lo[1]
        gx, gy = np.meshgrid(ix, iy, indexing="ij")
        return anchor_xy + self.cell_m * np.stack([gx, gy], axis=-1)
