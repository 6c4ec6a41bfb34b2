"""The last-measurement map: each cell holds the height of the latest frame that hit it.

The simplest height map a user might try: no fusion, no rays, no memory beyond one frame per
cell. A frame is one measurement of a cell: the cell takes the *highest* point of the frame that
falls into it (the top of what the camera saw there; a frame's points in one cell are parts of
one surface seen at once), replacing whatever an earlier frame left. A cell no frame hit since it
entered the grid has no height. It has no labels: ``fog()`` labels its heights with
:func:`mapper.backends.label_by_step`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mapper.backends import ScrollingGrid, StepRuleParams, frame_cells, label_by_step
from mapper.grid import UpdateResult, validate_frame
from mapper.params import MapperParams


class LastMeasurementMap(ScrollingGrid):
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
        super().__init__(self.params, center_xy_m)
        self._height = self._layer(np.nan)

    def update(
        self, points: ArrayLike, floor_heights: ArrayLike, sensor_origin: ArrayLike
    ) -> UpdateResult:
        """Replace the height of every cell the frame hits by the frame's highest point there.

        ``floor_heights`` and ``sensor_origin`` are validated but not used (no labels, no rays).
        Points outside the grid's x, y or z range are dropped and counted, as in the FOG.
        """
        pts, _, _ = validate_frame(points, floor_heights, sensor_origin)
        cells = frame_cells(pts, self._geometry)
        top = np.full(self._height.shape, np.nan)
        np.fmax.at(top, (cells.ix, cells.iy), pts[cells.inside, 2])  # NaN loses to any z
        hit = np.isfinite(top)
        self._height[hit] = top[hit]
        return cells.result(int(hit.sum()))

    def heights(self) -> NDArray[np.float64]:
        """(nx, ny) last height per cell [m], NaN where none."""
        return self._height.copy()

    def fog(self) -> tuple[NDArray[np.int8], NDArray[np.float64]]:
        """(labels by :func:`~mapper.backends.label_by_step`, heights [m] NaN = none)."""
        heights = self.heights()
        return label_by_step(heights, self.rule), heights
