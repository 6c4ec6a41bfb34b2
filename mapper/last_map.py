"""The last-measurement map: each cell holds the height of the latest frame that hit it.

The simplest height map a user might try: no fusion, no rays, no memory beyond one frame per
cell. A frame is one measurement of a cell: the cell takes the *highest* point of the frame that
falls into it (the top of what the camera saw there; a frame's points in one cell are parts of
one surface seen at once), replacing whatever an earlier frame left. A cell no frame hit since it
entered the grid has no height. It has no labels: ``fog()`` labels its heights with
:func:`mapper.backends.label_by_step`.
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from mapper.backends import StepRuleParams, label_by_step
from mapper.grid import AffectedArea, GridGeometry, UpdateResult, scroll_xy, validate_frame
from mapper.occupancy import NONFINITE, OUTSIDE, grid_point
from mapper.params import MapperParams


@numba.njit(cache=True)
def _frame_tops(points, origin_x, origin_y, z_min, cell, layer, nz, top):
    """Highest z of the frame's points per cell into ``top`` (NaN where none).

    Returns (used, nonfinite, outside, ix0, ix1, iy0, iy1).
    """
    nx, ny = top.shape
    used = 0
    nonfinite = 0
    outside = 0
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
        if not z <= top[ix, iy]:  # NaN (first point of the cell) or higher
            top[ix, iy] = z
        ix0 = min(ix0, ix)
        ix1 = max(ix1, ix)
        iy0 = min(iy0, iy)
        iy1 = max(iy1, iy)
    return used, nonfinite, outside, ix0, ix1 + 1, iy0, iy1 + 1


class LastMeasurementMap:
    """Per cell the highest point of the latest frame that hit it (see the module).

    Args:
        params: Only the grid geometry fields are used.
        rule: The labelling rule of ``fog()``.
        center_xy_m: World (x, y) [m] that lies in the central cell initially.
    """

    def __init__(
        self,
        params: MapperParams | None = None,
        rule: StepRuleParams | None = None,
        center_xy_m: ArrayLike = (0.0, 0.0),
    ) -> None:
        self.params = params if params is not None else MapperParams()
        self.rule = rule if rule is not None else StepRuleParams()
        self._geometry = GridGeometry.from_params(self.params, center_xy_m)
        self._height = np.full((self.params.nx, self.params.ny), np.nan)

    @property
    def geometry(self) -> GridGeometry:
        """Where the grid currently lies in the world."""
        return self._geometry

    def update(
        self, points: ArrayLike, floor_heights: ArrayLike, sensor_origin: ArrayLike
    ) -> UpdateResult:
        """Replace the height of every cell the frame hits by the frame's highest point there.

        ``floor_heights`` and ``sensor_origin`` are validated but not used (no labels, no rays).
        Points outside the grid's x, y or z range are dropped and counted, as in the FOG.
        """
        pts, _, _ = validate_frame(points, floor_heights, sensor_origin)
        g = self._geometry
        ox, oy = g.origin_xy_m
        top = np.full_like(self._height, np.nan)
        used, nonfinite, outside, ix0, ix1, iy0, iy1 = _frame_tops(
            pts, ox, oy, g.z_min_m, g.cell_m, g.layer_m, g.nz, top
        )
        hit = np.isfinite(top)
        self._height[hit] = top[hit]
        area = AffectedArea(int(ix0), int(ix1), int(iy0), int(iy1)) if used else None
        return UpdateResult(area, used, nonfinite, outside, 0, 0, int(hit.sum()))

    def heights(self) -> NDArray[np.float64]:
        """(nx, ny) last height per cell [m], NaN where none."""
        return self._height.copy()

    def fog(self) -> tuple[NDArray[np.int8], NDArray[np.float64]]:
        """(labels by :func:`~mapper.backends.label_by_step`, heights [m] NaN = none)."""
        heights = self.heights()
        return label_by_step(heights, self.rule), heights

    def recenter(self, x_m: float, y_m: float) -> tuple[int, int]:
        """Scroll by whole cells so world (x, y) lies in the central cell; entering cells empty.

        Raises:
            InvalidInputError: as `FloorObstacleMapper.recenter`.
        """
        sx, sy = self._geometry.shift_to(x_m, y_m)
        if sx == 0 and sy == 0:
            return (0, 0)
        scroll_xy(self._height, sx, sy, np.nan)
        self._geometry = self._geometry.shifted(sx, sy)
        return (sx, sy)
