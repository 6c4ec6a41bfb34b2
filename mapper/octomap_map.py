"""OctoMap (Hornung et al. 2013) through ``octomap-python``, read as a height map.

Every frame goes into an ``octomap.OcTree`` with ``insertPointCloud`` (OctoMap's own ray
insertion: each voxel a ray crosses gets one miss, each endpoint voxel one hit, per frame). The
height of a column is the top face of its highest occupied voxel within the grid's z range — the
number a user reading an OctoMap as a height map gets. The tree's resolution is the grid's cell
side (``layer_m`` must equal ``cell_m``: voxels are cubes), and the points are shifted down by
``z_min_m`` before insertion so the voxels' z faces fall on the grid's layer faces (x and y faces
already fall on the cell faces, both at multiples of ``cell_m``). OctoMap keeps every voxel it
ever saw; ``recenter`` only moves the window that is read out.

It has no floor/obstacle labels: ``fog()`` labels its heights with
:func:`mapper.backends.label_by_step`. ``octomap-python`` is imported when a map is made, so the
rest of the library does not need it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mapper.backends import ScrollingGrid, StepRuleParams, label_by_step
from mapper.errors import InvalidParameterError
from mapper.grid import UpdateResult, validate_frame
from mapper.params import MapperParams
from mapper.validation import check_field

_EDGE_M = 1e-6
"""Inset of the read-out box from the window's faces [m], so no voxel of a neighbouring column
or of the layer above the grid is read."""


@dataclass(frozen=True)
class OctoMapParams:
    """OctoMap's sensor model (defaults: OctoMap's and octomap_server's).

    Attributes:
        prob_hit: Probability of a hit in an endpoint voxel: 0.7.
        prob_miss: Probability of a hit in a voxel a ray crosses: 0.4.
        clamping_min: Lower clamping probability: 0.1192.
        clamping_max: Upper clamping probability: 0.971.
        occupancy_threshold: A voxel above this is occupied: 0.5.
        max_range_m: Rays longer than this insert only up to it [m]; inf = the whole ray
            (octomap_server's default, -1 there).
    """

    prob_hit: float = 0.7
    prob_miss: float = 0.4
    clamping_min: float = 0.1192
    clamping_max: float = 0.971
    occupancy_threshold: float = 0.5
    max_range_m: float = math.inf

    def __post_init__(self) -> None:
        probability = "in (0, 1)"
        for name in ("prob_hit", "prob_miss", "clamping_min", "clamping_max"):
            check_field(
                "OctoMapParams", name, getattr(self, name), float, probability, lambda v: 0 < v < 1
            )
        check_field(
            "OctoMapParams",
            "occupancy_threshold",
            self.occupancy_threshold,
            float,
            f"in [clamping_min, clamping_max] = [{self.clamping_min}, {self.clamping_max}]",
            lambda v: self.clamping_min <= v <= self.clamping_max,
        )
        check_field(
            "OctoMapParams",
            "max_range_m",
            self.max_range_m,
            float,
            "> 0 [m] or inf",
            lambda v: v > 0,
        )


class OctoMapHeights(ScrollingGrid):
    """An OctoMap read out as the top of the highest occupied voxel per column (see the module).

    Args:
        params: OctoMap's sensor model.
        grid: The grid geometry (the FOG's, so cells coincide); ``layer_m`` must equal
            ``cell_m``.
        rule: The labelling rule of ``fog()``.
        center_xy_m: World (x, y) [m] that lies in the central cell initially.

    Raises:
        InvalidParameterError: ``grid.layer_m`` differs from ``grid.cell_m``.
    """

    def __init__(
        self,
        params: OctoMapParams | None = None,
        grid: MapperParams | None = None,
        rule: StepRuleParams | None = None,
        center_xy_m: ArrayLike = (0.0, 0.0),
    ) -> None:
        import octomap  # the octomap extra (module doc)

        self.params = params if params is not None else OctoMapParams()
        self.grid = grid if grid is not None else MapperParams()
        self.rule = rule if rule is not None else StepRuleParams()
        if self.grid.layer_m != self.grid.cell_m:
            raise InvalidParameterError(
                f"OctoMapHeights needs cubic voxels: MapperParams.layer_m must equal cell_m "
                f"({self.grid.cell_m!r}), got {self.grid.layer_m!r}"
            )
        super().__init__(self.grid, center_xy_m)  # no layers: the tree keeps every voxel
        p = self.params
        tree = octomap.OcTree(self.grid.cell_m)
        tree.setProbHit(p.prob_hit)
        tree.setProbMiss(p.prob_miss)
        tree.setClampingThresMin(p.clamping_min)
        tree.setClampingThresMax(p.clamping_max)
        tree.setOccupancyThres(p.occupancy_threshold)
        self.tree = tree
        self._shift = np.array([0.0, 0.0, self.grid.z_min_m])

    def update(
        self, points: ArrayLike, floor_heights: ArrayLike, sensor_origin: ArrayLike
    ) -> UpdateResult:
        """Insert one frame's finite points with their rays (``floor_heights`` unused).

        Every finite point is inserted, inside the window or not (its ray clears what it
        crosses, as in OctoMap); ``points_used`` counts them, ``affected_area`` is None (the
        tree is not a grid).
        """
        pts, _, origin = validate_frame(points, floor_heights, sensor_origin)
        finite = np.isfinite(pts).all(axis=1)
        max_range = self.params.max_range_m
        self.tree.insertPointCloud(
            np.ascontiguousarray(pts[finite] - self._shift),
            origin - self._shift,
            maxrange=max_range if math.isfinite(max_range) else -1.0,
        )
        used = int(finite.sum())
        return UpdateResult(None, used, int((~finite).sum()), 0, 0, 0, 0)

    def heights(self) -> NDArray[np.float64]:
        """(nx, ny) top [m] of each column's highest occupied voxel in the grid's z range."""
        g = self._geometry
        ox, oy = g.origin_xy_m
        top = np.full((g.nx, g.ny), -np.inf)
        low = np.array([ox + _EDGE_M, oy + _EDGE_M, _EDGE_M])
        high = np.array([ox + g.nx * g.cell_m, oy + g.ny * g.cell_m, g.nz * g.layer_m]) - _EDGE_M
        tree = self.tree
        for leaf in tree.begin_leafs_bbx(low, high):
            if not tree.isNodeOccupied(leaf):
                continue
            half = 0.5 * leaf.getSize()
            x, y, z = leaf.getCoordinate()
            column_top = min(z + half, g.nz * g.layer_m) + g.z_min_m
            ix0 = max(round((x - half - ox) / g.cell_m), 0)
            ix1 = min(round((x + half - ox) / g.cell_m), g.nx)
            iy0 = max(round((y - half - oy) / g.cell_m), 0)
            iy1 = min(round((y + half - oy) / g.cell_m), g.ny)
            block = top[ix0:ix1, iy0:iy1]
            np.maximum(block, column_top, out=block)
        return np.where(np.isfinite(top), top, np.nan)

    def fog(self) -> tuple[NDArray[np.int8], NDArray[np.float64]]:
        """(labels by :func:`~mapper.backends.label_by_step`, heights [m] NaN = none)."""
        heights = self.heights()
        return label_by_step(heights, self.rule), heights
