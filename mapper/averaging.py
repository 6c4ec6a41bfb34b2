"""The Kagami-style baseline the paper compares against (Fig. 5): per-cell mean of point heights.

No 3D grid and no rays: every point adds its z to the running mean of its (x, y) cell, forever.
So a removed object is only forgotten in cells that later receive enough new points, and a box
slid slowly leaves heights between its top and the ground — the behaviour the paper shows.

Kagami's map has no floor/obstacle distinction; for comparability ``fog()`` labels a cell FLOOR
when the majority of its points were floor-labelled (finite ``h``), else OBSTACLE, with the
mean height of all its points; cells without points are UNKNOWN. ``floor()`` is the mean ``h``
of the floor-labelled points, NaN where none.
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from mapper.grid import (
    AffectedArea,
    CellType,
    GridGeometry,
    UpdateResult,
    scroll_xy,
    validate_frame,
)
from mapper.occupancy import NONFINITE, OUTSIDE, grid_point
from mapper.params import MapperParams


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _accumulate(
    points, heights, origin_x, origin_y, z_min, cell, layer, nz, sum_z, count, sum_h, floor_count
):
    """Add points to the per-cell sums; returns (used, nonfinite, outside, floor, ix0..iy1)."""
    nx, ny = count.shape
    used = 0
    nonfinite = 0
    outside = 0
    n_floor = 0
    ix0 = nx
    ix1 = -1
    iy0 = ny
    iy1 = -1
    for i in range(points.shape[0]):
        z = points[i, 2]
        status, _, _, _, ix, iy, _ = grid_point(
            points[i, 0], points[i, 1], z, origin_x, origin_y, z_min, cell, layer, nx, ny, nz
        )
        if status < 0:
            nonfinite += status == NONFINITE
            outside += status == OUTSIDE
            continue
        used += 1
        sum_z[ix, iy] += z
        count[ix, iy] += 1
        h = heights[i]
        if np.isfinite(h):
            sum_h[ix, iy] += h
            floor_count[ix, iy] += 1
            n_floor += 1
        ix0 = min(ix0, ix)
        ix1 = max(ix1, ix)
        iy0 = min(iy0, iy)
        iy1 = max(iy1, iy)
    return used, nonfinite, outside, n_floor, ix0, ix1 + 1, iy0, iy1 + 1


class AveragingMap:
    """Running per-cell average of observed heights (Kagami et al.), same interface as the FOG.

    Args:
        params: Only the grid geometry fields are used.
        center_xy_m: World (x, y) [m] that lies in the central cell initially.
    """

    def __init__(
        self, params: MapperParams | None = None, center_xy_m: ArrayLike = (0.0, 0.0)
    ) -> None:
        self.params = params if params is not None else MapperParams()
        p = self.params
        self._geometry = GridGeometry.from_params(p, center_xy_m)
        self._sum_z = np.zeros((p.nx, p.ny))
        self._count = np.zeros((p.nx, p.ny), dtype=np.int64)
        self._sum_h = np.zeros((p.nx, p.ny))
        self._floor_count = np.zeros((p.nx, p.ny), dtype=np.int64)

    @property
    def geometry(self) -> GridGeometry:
        """Where the grid currently lies in the world."""
        return self._geometry

    def update(
        self, points: ArrayLike, floor_heights: ArrayLike, sensor_origin: ArrayLike
    ) -> UpdateResult:
        """Add one frame of points to the running means (``sensor_origin`` is only validated).

        ``cells_updated`` of the result counts the points added (there is no 3D grid).

        Points outside the grid's x, y or z range are dropped and counted, as in the FOG mapper.
        """
        pts, heights, _ = validate_frame(points, floor_heights, sensor_origin)
        g = self._geometry
        ox, oy = g.origin_xy_m
        used, nonfinite, outside, n_floor, ix0, ix1, iy0, iy1 = _accumulate(
            pts,
            heights,
            ox,
            oy,
            g.z_min_m,
            g.cell_m,
            g.layer_m,
            g.nz,
            self._sum_z,
            self._count,
            self._sum_h,
            self._floor_count,
        )
        area = AffectedArea(int(ix0), int(ix1), int(iy0), int(iy1)) if used else None
        return UpdateResult(area, used, nonfinite, outside, n_floor, 0, used)

    def heights(self) -> NDArray[np.float64]:
        """(nx, ny) mean z of all points per cell [m], NaN where none."""
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(self._count > 0, self._sum_z / self._count, np.nan)

    def floor(self) -> NDArray[np.float64]:
        """(nx, ny) mean floor height of the floor-labelled points [m], NaN where none."""
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(self._floor_count > 0, self._sum_h / self._floor_count, np.nan)

    def fog(self) -> tuple[NDArray[np.int8], NDArray[np.float64]]:
        """(types (nx, ny) int8 `CellType`, mean heights [m] NaN=unknown); see module doc."""
        types = np.full(self._count.shape, CellType.UNKNOWN, dtype=np.int8)
        seen = self._count > 0
        floor_majority = 2 * self._floor_count > self._count
        types[seen & floor_majority] = CellType.FLOOR
        types[seen & ~floor_majority] = CellType.OBSTACLE
        return types, self.heights()

    def recenter(self, x_m: float, y_m: float) -> tuple[int, int]:
        """Scroll by whole cells so world (x, y) lies in the central cell; entering cells empty.

        Raises:
            InvalidInputError: as `FloorObstacleMapper.recenter`.
        """
        sx, sy = self._geometry.shift_to(x_m, y_m)
        if sx == 0 and sy == 0:
            return (0, 0)
        for array in (self._sum_z, self._count, self._sum_h, self._floor_count):
            scroll_xy(array, sx, sy, 0)
        self._geometry = self._geometry.shifted(sx, sy)
        return (sx, sy)
