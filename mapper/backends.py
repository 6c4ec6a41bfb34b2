"""The one interface every height map offers, and the one labelling rule for maps without labels.

:class:`HeightMapBackend` is the interface the FOG (:class:`~mapper.mapper.FloorObstacleMapper`)
and the averaging map (:class:`~mapper.averaging.AveragingMap`) already share and the other maps
of the comparison (:mod:`mapper.elevation_map`, :mod:`mapper.last_map`,
:mod:`mapper.octomap_map`) implement: ``update(points, floor_heights, sensor_origin)`` with a
frame's world points, their floor heights (NaN = not floor) and the camera centre;
``recenter(x, y)`` to follow the robot by whole cells; ``fog()`` for the labels and heights of
the current grid; ``geometry`` for where that grid lies.

Maps that know no floor and obstacle (an elevation map, the last measurement, OctoMap) label
their heights with :func:`label_by_step`, one rule applied to every map alike, the FOG included
when it is scored on its heights alone: a cell is FLOOR when the heights in the foot-sized window
around it span at most ``max_step_m``, OBSTACLE otherwise, UNKNOWN without a height.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mapper.grid import AffectedArea, CellType, GridGeometry, UpdateResult, scroll_xy
from mapper.params import MapperParams
from mapper.validation import check_field


@runtime_checkable
class HeightMapBackend(Protocol):
    """What the comparison drives: one frame in, the current grid's labels and heights out."""

    @property
    def geometry(self) -> GridGeometry:
        """Where the current grid lies in the world."""
        ...

    def update(
        self, points: ArrayLike, floor_heights: ArrayLike, sensor_origin: ArrayLike
    ) -> UpdateResult:
        """Add one frame: (N, 3) world points [m], (N,) floor heights [m], camera centre [m]."""
        ...

    def recenter(self, x_m: float, y_m: float) -> tuple[int, int]:
        """Scroll by whole cells so world (x, y) lies in the central cell; returns the shift."""
        ...

    def fog(self) -> tuple[NDArray[np.int8], NDArray[np.float64]]:
        """(nx, ny) `CellType` labels and heights [m] (NaN = none) of the current grid."""
        ...


@dataclass(frozen=True)
class FrameCells:
    """Where a frame's points fall on a grid (the first step of every map's ``update``).

    Attributes:
        ix: (M,) x index of each point inside the grid, in point order.
        iy: (M,) y index of each.
        inside: (N,) the point is finite and inside the grid's x, y and z range.
        nonfinite: Points with a coordinate that is not finite.
        outside: Finite points outside the grid.
        area: Bounding box of the cells hit, None when no point is inside.
    """

    ix: NDArray[np.int64]
    iy: NDArray[np.int64]
    inside: NDArray[np.bool_]
    nonfinite: int
    outside: int
    area: AffectedArea | None

    def result(self, cells_updated: int) -> UpdateResult:
        """The ``UpdateResult`` of a map without floor points: these counts and the area."""
        used = int(self.inside.sum())
        return UpdateResult(self.area, used, self.nonfinite, self.outside, 0, 0, cells_updated)


def frame_cells(points: NDArray[np.float64], geometry: GridGeometry) -> FrameCells:
    """The cells of a frame's (N, 3) world points [m] (``GridGeometry.cell_of``'s convention)."""
    index, inside = geometry.cell_of(points)
    finite = np.isfinite(points).all(axis=1)
    ix, iy = index[inside, 0], index[inside, 1]
    area = (
        AffectedArea(int(ix.min()), int(ix.max()) + 1, int(iy.min()), int(iy.max()) + 1)
        if ix.size
        else None
    )
    return FrameCells(ix, iy, inside, int((~finite).sum()), int((finite & ~inside).sum()), area)


class ScrollingGrid:
    """A robot-centred grid of per-cell arrays that scroll together (the maps' ``recenter``).

    Args:
        params: The grid geometry fields (the FOG's, so cells coincide).
        center_xy_m: World (x, y) [m] that lies in the central cell initially.
    """

    def __init__(self, params: MapperParams, center_xy_m: ArrayLike = (0.0, 0.0)) -> None:
        self._geometry = GridGeometry.from_params(params, center_xy_m)
        self._layers: list[tuple[NDArray[np.generic], float]] = []

    def _layer(self, fill: float, dtype: type = np.float64) -> NDArray[np.generic]:
        """A new (nx, ny) array filled with ``fill`` that scrolls with the grid."""
        g = self._geometry
        array = np.full((g.nx, g.ny), fill, dtype=dtype)
        self._layers.append((array, fill))
        return array

    @property
    def geometry(self) -> GridGeometry:
        """Where the grid currently lies in the world."""
        return self._geometry

    def recenter(self, x_m: float, y_m: float) -> tuple[int, int]:
        """Scroll by whole cells so world (x, y) lies in the central cell; entering cells empty.

        Raises:
            InvalidInputError: as `FloorObstacleMapper.recenter`.
        """
        sx, sy = self._geometry.shift_to(x_m, y_m)
        if sx == 0 and sy == 0:
            return (0, 0)
        for array, fill in self._layers:
            scroll_xy(array, sx, sy, fill)
        self._geometry = self._geometry.shifted(sx, sy)
        return (sx, sy)


@dataclass(frozen=True)
class StepRuleParams:
    """The labelling rule for maps without labels (:func:`label_by_step`).

    Attributes:
        window_cells: Side of the square window around a cell, in cells (odd). 3 cells of the
            default 4 cm are 12 cm, between the width (6 cm) and the length (15.6 cm) of the
            iCub's sole (the testbed's default robot): about the area a foot stands on.
        max_step_m: Largest height span within the window that is still floor [m]. 0.05 m,
            the FOG's own obstacle threshold δ (``MapperParams.delta_m``), so that the rule
            and eq. 11 draw the line at the same height.
    """

    window_cells: int = 3
    max_step_m: float = 0.05

    def __post_init__(self) -> None:
        check_field(
            "StepRuleParams",
            "window_cells",
            self.window_cells,
            int,
            "an odd integer >= 1",
            lambda v: v >= 1 and v % 2 == 1,
        )
        check_field(
            "StepRuleParams",
            "max_step_m",
            self.max_step_m,
            float,
            "a finite float >= 0 [m]",
            lambda v: math.isfinite(v) and v >= 0,
        )


def label_by_step(
    heights_m: NDArray[np.floating], params: StepRuleParams | None = None
) -> NDArray[np.int8]:
    """Floor / obstacle / unknown labels of a height map by the step within a foot's window.

    Args:
        heights_m: (nx, ny) heights [m], NaN = none.
        params: The rule (default :class:`StepRuleParams`).

    Returns:
        (nx, ny) `CellType` values: UNKNOWN where the height is NaN; FLOOR where the finite
        heights of the ``window_cells`` × ``window_cells`` window centred on the cell (cut at the
        grid's border) span at most ``max_step_m``; OBSTACLE otherwise.
    """
    p = params if params is not None else StepRuleParams()
    heights = np.asarray(heights_m, dtype=np.float64)
    known = np.isfinite(heights)
    nx, ny = heights.shape
    half = p.window_cells // 2
    tops = np.pad(np.where(known, heights, -np.inf), half, constant_values=-np.inf)
    bottoms = np.pad(np.where(known, heights, np.inf), half, constant_values=np.inf)
    high = np.full(heights.shape, -np.inf)
    low = np.full(heights.shape, np.inf)
    for dx in range(p.window_cells):  # window offsets, each a whole-grid operation
        for dy in range(p.window_cells):
            np.maximum(high, tops[dx : dx + nx, dy : dy + ny], out=high)
            np.minimum(low, bottoms[dx : dx + nx, dy : dy + ny], out=low)
    step = high - low
    labels = np.full(heights.shape, CellType.UNKNOWN, dtype=np.int8)
    labels[known & (step <= p.max_step_m)] = CellType.FLOOR
    labels[known & (step > p.max_step_m)] = CellType.OBSTACLE
    return labels
