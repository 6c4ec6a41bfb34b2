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
from mapper.params import MapperParams


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

        Points outside the grid's x, y or z range are dropped and counted, as in the FOG mapper.
        """
        pts, heights, _ = validate_frame(points, floor_heights, sensor_origin)
        finite = np.all(np.isfinite(pts), axis=1)
        idx, inside = self._geometry.cell_of(pts)
        n_nonfinite = int(np.count_nonzero(~finite))
        n_outside = int(np.count_nonzero(finite & ~inside))
        if not np.any(inside):
            return UpdateResult(None, 0, n_nonfinite, n_outside, 0, 0, 0)
        p = self.params
        col = idx[inside, 0] * p.ny + idx[inside, 1]
        size = p.nx * p.ny
        self._sum_z += np.bincount(col, weights=pts[inside, 2], minlength=size).reshape(p.nx, p.ny)
        counts = np.bincount(col, minlength=size)
        self._count += counts.reshape(p.nx, p.ny)
        h = heights[inside]
        is_floor = np.isfinite(h)
        self._sum_h += np.bincount(col[is_floor], weights=h[is_floor], minlength=size).reshape(
            p.nx, p.ny
        )
        self._floor_count += np.bincount(col[is_floor], minlength=size).reshape(p.nx, p.ny)
        ix, iy = idx[inside, 0], idx[inside, 1]
        area = AffectedArea(int(ix.min()), int(ix.max()) + 1, int(iy.min()), int(iy.max()) + 1)
        n_floor = int(np.count_nonzero(is_floor))
        return UpdateResult(
            area, int(col.size), n_nonfinite, n_outside, n_floor, 0, int(np.count_nonzero(counts))
        )

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
        """Scroll by whole cells so world (x, y) lies in the central cell; entering cells empty."""
        sx, sy = self._geometry.shift_to(float(x_m), float(y_m))
        if sx == 0 and sy == 0:
            return (0, 0)
        for array in (self._sum_z, self._count, self._sum_h, self._floor_count):
            scroll_xy(array, sx, sy, 0)
        self._geometry = self._geometry.shifted(sx, sy)
        return (sx, sy)
