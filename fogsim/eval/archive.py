"""The world-fixed archive of a run's maps: the last value of every map in every cell.

The mapper's grids follow the robot and scroll by whole cells, so a run is scored on a
:class:`WorldArchive`: a world-fixed lattice of the mapper's cells that keeps, for every cell
that was ever inside the map, the last FOG, floor, obstacle, ceiling and averaging-baseline value
it had there, and whether the camera ever saw it (:func:`cells_in_view`). Arrays are indexed
``[ix, iy]`` over the lattice, heights in metres in the world frame, NaN = none.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from fogsim.data.frame import Frame
from fogsim.errors import FogsimError
from mapper import CellType
from mapper.grid import GridGeometry
from mapper.transforms import apply_transform


def cells_in_view(frame: Frame, geometry: GridGeometry) -> NDArray[np.bool_]:
    """(nx, ny) cells of a grid that the frame's camera saw.

    A cell is in view when a depth measurement of the frame, placed in the world with the
    *true* camera pose, lies in one of the cell's layers (inside the grid's height range: what
    lies above or below it cannot be mapped). Pixels without a measurement (NaN: dropouts, out
    of range, the robot's own body) see nothing; a frame without a true pose (real data, NaN)
    sees no cell.
    """
    points_camera = frame.intrinsics.depth_to_points_camera(frame.depth_m).reshape(-1, 3)
    points_world = apply_transform(frame.transform_camera_to_world_true, points_camera)
    index, inside = geometry.cell_of(points_world)
    seen = np.zeros((geometry.nx, geometry.ny), dtype=bool)
    seen[index[inside, 0], index[inside, 1]] = True
    return seen


class WorldArchive:
    """World-fixed lattice of the mapper's cells: the last value of each map in each cell.

    The lattice is anchored at the first grid's cell centres; the mapper scrolls by whole cells,
    so every later grid lies on it. Storage grows as the robot walks (bounding box of all grids).

    Attributes:
        cell_m: Cell side [m].
        fog_types: (nx, ny) last FOG label (``mapper.CellType``), UNKNOWN where never in a map.
        fog_heights_m: (nx, ny) last FOG height [m] (floor height or coarse obstacle top).
        floor_m: (nx, ny) last floor height of the floor map [m].
        obstacle_m: (nx, ny) last coarse obstacle height (eq. 10) [m].
        ceiling_m: (nx, ny) last ceiling height (the paper's extension) [m].
        baseline_heights_m: (nx, ny) last averaging-baseline height [m].
        visited: (nx, ny) the cell was inside the map in some frame (the scored region).
        in_view: (nx, ny) the camera saw the cell in some frame (:func:`cells_in_view`).
    """

    def __init__(self, cell_m: float) -> None:
        self.cell_m = float(cell_m)
        self._anchor_xy: NDArray[np.float64] | None = None
        self._lo = np.zeros(2, dtype=np.int64)  # lattice index of array cell [0, 0]
        self.fog_types = np.zeros((0, 0), dtype=np.int8)
        self.fog_heights_m = np.zeros((0, 0))
        self.floor_m = np.zeros((0, 0))
        self.obstacle_m = np.zeros((0, 0))
        self.ceiling_m = np.zeros((0, 0))
        self.baseline_heights_m = np.zeros((0, 0))
        self.visited = np.zeros((0, 0), dtype=bool)
        self.in_view = np.zeros((0, 0), dtype=bool)

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
            (self.floor_m, np.nan),
            (self.obstacle_m, np.nan),
            (self.ceiling_m, np.nan),
            (self.baseline_heights_m, np.nan),
            (self.visited, False),
            (self.in_view, False),
        ):
            grown = np.full(shape, fill, dtype=old.dtype)
            if old.size:
                grown[
                    before[0] : before[0] + old.shape[0], before[1] : before[1] + old.shape[1]
                ] = old
            arrays.append(grown)
        (
            self.fog_types,
            self.fog_heights_m,
            self.floor_m,
            self.obstacle_m,
            self.ceiling_m,
            self.baseline_heights_m,
            self.visited,
            self.in_view,
        ) = arrays
        self._lo = new_lo

    def store(
        self,
        cell_centers_xy: NDArray[np.floating],
        fog_types: NDArray[np.integer],
        fog_heights_m: NDArray[np.floating],
        baseline_heights_m: NDArray[np.floating],
        *,
        floor_m: NDArray[np.floating],
        obstacle_m: NDArray[np.floating],
        ceiling_m: NDArray[np.floating],
        in_view: NDArray[np.bool_],
    ) -> None:
        """Copy the current maps (nx, ny) with their cell centres (nx, ny, 2) into the archive.

        Every map replaces the archive's values of its cells; ``in_view`` (this frame's
        :func:`cells_in_view`) is added to the cells seen before.
        """
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
        self.floor_m[sl] = floor_m
        self.obstacle_m[sl] = obstacle_m
        self.ceiling_m[sl] = ceiling_m
        self.baseline_heights_m[sl] = baseline_heights_m
        self.visited[sl] = True
        self.in_view[sl] |= np.asarray(in_view, dtype=bool)

    def is_empty(self) -> bool:
        """The FOG labelled no cell floor or obstacle (or nothing was stored)."""
        return not bool((self.visited & (self.fog_types != CellType.UNKNOWN)).any())

    def cell_centers_xy(self) -> NDArray[np.float64]:
        """(nx, ny, 2) world centres [m] of the archive's cells."""
        anchor_xy = self._anchor()
        ix = np.arange(self.visited.shape[0]) + self._lo[0]
        iy = np.arange(self.visited.shape[1]) + self._lo[1]
        gx, gy = np.meshgrid(ix, iy, indexing="ij")
        return anchor_xy + self.cell_m * np.stack([gx, gy], axis=-1)
