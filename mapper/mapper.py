"""FloorObstacleMapper: the paper's 3D occupancy grid + floor height map + FOG, kept up to date.

One ``update`` is the paper's Fig. 2 after the (optional, caller-side) z matching:
insert the points into the 3D grid (rays, eqs. 6, 12, 13), verify the floor map in the affected
area (eq. 8), update it with the floor points (eqs. 7, 9); the obstacle heights and the FOG
(eqs. 10, 11) of the areas updated since are recomputed when they are read (``fog``,
``obstacle``) or the grids scroll, bit for bit what recomputing them after every update gives
(`FloorObstacleMapper._refresh_fog`). All grids are world-anchored in x, y (see
`mapper.grid`) and scroll by whole cells with ``recenter``; z is absolute.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mapper.above_top import MIN_HIT_POINTS, update_above_top
from mapper.errors import InvalidParameterError
from mapper.floor_cover import accumulate_cover, frame_floor_heights
from mapper.floor_edges import count_split_frames, mark_floor_edges
from mapper.floor_map import frame_verdicts, update_floor, verify_floor
from mapper.fog import ceiling_map, mark_raised_rims, mark_unconfirmed_floors, update_fog_area
from mapper.grid import (
    AffectedArea,
    CellType,
    GridGeometry,
    UpdateResult,
    scroll_xy,
    validate_frame,
)
from mapper.occupancy import (
    MAX_COLUMN_LAYERS,
    cell_set,
    column_mask_dtype,
    insert_frame,
    insert_frame_columns,
    layer_range_masks,
    lookup_tables,
    mark_buffer_size,
    update_table,
)
from mapper.params import LEVEL_UNKNOWN, LEVELS, MapperParams
from mapper.validation import real_scalar
from mapper.zmatch import ZMatch, match_z


def _rewritten_ring(p: MapperParams) -> int:
    """Cells beyond the stale area that `update_fog_area` rewrites (its ring) [cells].

    The margin, the band's 2, the narrow rise's n + 1, the shadow's reach + 1 and one more for
    `MapperParams.min_floor_neighbours`; the rules after it (`mapper.fog.mark_raised_rims`,
    `mapper.fog.mark_unconfirmed_floors`, `mapper.floor_edges`) judge exactly that window, so
    it reaches as far as they read: a neighbour for the split and weak-foot rules, the cell
    beyond it and `MapperParams.narrow_rise_cells` the other way for the uncovered rims.
    """
    banded = p.edge_band_m > 0.0 or p.unknown_beside_obstacles
    ring = p.obstacle_margin_cells + (2 if banded else 0)
    if p.edge_band_m > 0.0 and p.narrow_rise_cells > 0:
        ring = max(ring, p.narrow_rise_cells + 1)
    if p.edge_band_m > 0.0 and p.shadow_reach_cells > 1:
        ring = max(ring, p.shadow_reach_cells + 1)
    if p.edge_band_m > 0.0 and p.min_floor_neighbours > 0:
        ring += 1
    if p.splits_edges or p.weak_foot_frames > 0:
        ring = max(ring, 1)
    if p.judges_uncovered_rims:
        ring = max(ring, 2, p.narrow_rise_cells)
    return ring


class FloorObstacleMapper:
    """The floor and obstacle height map of Gutmann, Fukuchi and Fujita.

    All heights handed out are world z [m] with NaN for invalid. The first ``update`` compiles
    the numba kernels (about a second, once per machine thanks to numba's cache).

    Args:
        params: Grid geometry and thresholds (defaults: the paper's grid).
        center_xy_m: World (x, y) [m] that lies in the central cell initially.
        column_marks: How a frame's once-per-cell marks are kept: True = one bit per layer in a
            word per column (`insert_frame_columns`, fast; needs ``nz <= 64``), False = one bit
            per cell (`insert_frame`), None = True when the column fits a word. Both give the
            same map (benchmarks compare them).

    Raises:
        InvalidParameterError: ``column_marks=True`` with ``nz > 64``.
        InvalidInputError: ``center_xy_m`` is not two finite coordinates within
            ±`mapper.limits.MAX_COORDINATE_M`.
    """

    def __init__(
        self,
        params: MapperParams | None = None,
        center_xy_m: ArrayLike = (0.0, 0.0),
        *,
        column_marks: bool | None = None,
    ) -> None:
        self.params = params if params is not None else MapperParams()
        p = self.params
        # `MapperParams.min_floor_frames` needs the frame votes (`floor_frame_cap` > 0).
        self._confirms_floors = p.min_floor_frames > 1 and p.floor_frame_cap > 0
        # `mapper.floor_edges.mark_floor_edges`: the split, weak-foot and uncovered-rim rules
        # (the split frames are counted only with `MapperParams.splits_edges`: 0.02 ms of the
        # stage's 0.81 ms update).
        self._marks_edges = p.splits_edges or p.weak_foot_frames > 0 or p.judges_uncovered_rims
        self._fog_ring = _rewritten_ring(p)
        self._geometry = GridGeometry.from_params(p, center_xy_m)
        self._hit_table, self._miss_table = lookup_tables(p)
        self._occ_level = p.occ_threshold_level
        self._og = np.full((p.nx, p.ny, p.nz), LEVEL_UNKNOWN, dtype=np.uint8)
        self._floor = np.full((p.nx, p.ny), np.nan)
        self._floor_weights = np.zeros((p.nx, p.ny))
        self._floor_votes = np.zeros((p.nx, p.ny), dtype=np.int32)
        self._floor_frame_votes = np.zeros((p.nx, p.ny), dtype=np.int32)
        # Frames that split each column between two planes, of those with two floor points
        # or more, and the scratch that counts them (`mapper.floor_edges`).
        self._split_frames = np.zeros((p.nx, p.ny), dtype=np.int32)
        self._lower_split_frames = np.zeros((p.nx, p.ny), dtype=np.int32)
        self._multi_frames = np.zeros((p.nx, p.ny), dtype=np.int32)
        self._split_scratch = (
            np.full(p.nx * p.ny, np.inf),
            np.full(p.nx * p.ny, -np.inf),
            np.zeros(p.nx * p.ny, dtype=np.int32),
        )
        self._cover_ref = np.full((p.nx, p.ny), np.nan)
        self._cover_ends = np.zeros((p.nx, p.ny), dtype=np.int32)
        self._cover_passes = np.zeros((p.nx, p.ny), dtype=np.int32)
        self._obstacle = np.full((p.nx, p.ny), np.nan)
        self._fog_types = np.full((p.nx, p.ny), CellType.UNKNOWN, dtype=np.int8)
        self._fog_heights = np.full((p.nx, p.ny), np.nan)
        # Something just above the grid's top, per column (`mapper.above_top`).
        self._above_top = np.full((p.nx, p.ny), LEVEL_UNKNOWN, dtype=np.uint8)
        self._above_counts = np.zeros(p.nx * p.ny, dtype=np.int32)  # scratch, kept zero
        self._above_scratch = np.empty(0, dtype=np.int64)  # touched columns, grown as needed
        # Where the two above are stale (`_refresh_fog`); None: nowhere.
        self._stale_area: AffectedArea | None = None
        # Once-per-frame marks: one bit per layer in a word per column when the column fits one
        # word (`insert_frame_columns`, the fast path), else one bit per cell (`insert_frame`).
        if column_marks and p.nz > MAX_COLUMN_LAYERS:
            raise InvalidParameterError(
                f"column_marks=True needs MapperParams.nz <= {MAX_COLUMN_LAYERS}, got {p.nz}"
            )
        self._columns = p.nz <= MAX_COLUMN_LAYERS if column_marks is None else column_marks
        if p.repeat_ray_columns > 0 and not self._columns:
            raise InvalidParameterError(
                "MapperParams.repeat_ray_columns > 0 needs the column marks (column_marks=True "
                f"or None, nz <= {MAX_COLUMN_LAYERS}), got repeat_ray_columns="
                f"{p.repeat_ray_columns} with column_marks={column_marks}, nz={p.nz}"
            )
        if self._columns:
            dtype = column_mask_dtype(p.nz)
            self._hit_cols = np.zeros(p.nx * p.ny, dtype=dtype)
            self._miss_cols = np.zeros(p.nx * p.ny, dtype=dtype)
            self._range_masks = layer_range_masks(p.nz)
            self._update_table = update_table(self._hit_table, self._miss_table)
        else:
            self._mark = np.zeros(mark_buffer_size(p.cell_count), dtype=np.uint8)
            self._touched = np.empty(p.cell_count, dtype=np.int64)

    # ------------------------------------------------------------------ geometry
    @property
    def geometry(self) -> GridGeometry:
        """Where the grids currently lie in the world."""
        return self._geometry

    @property
    def origin_xy_m(self) -> tuple[float, float]:
        """World (x, y) of the grid's corner [m]."""
        return self._geometry.origin_xy_m

    def cell_of(self, points_world: ArrayLike) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
        """Cell indices (N, 3) (or (N, 2)) of world points and their validity; see GridGeometry."""
        return self._geometry.cell_of(points_world)

    def cell_center(self, ix: ArrayLike, iy: ArrayLike, iz: ArrayLike | None = None):
        """World centre [m] of cells; see `GridGeometry.cell_center`."""
        return self._geometry.cell_center(ix, iy, iz)

    # ------------------------------------------------------------------ update
    def update(
        self, points: ArrayLike, floor_heights: ArrayLike, sensor_origin: ArrayLike
    ) -> UpdateResult:
        """Insert one frame of labelled points.

        Args:
            points: (N, 3) points in the world frame [m]; rows with NaN/inf are dropped and
                counted. Rows outside the grid (x, y or z) or farther than
                ``params.max_range_m`` from the sensor are no hit and counted; with
                ``params.clear_outside`` their rays still clear the grid cells they cross
                (see `MapperParams.clear_outside`).
            floor_heights: (N,) height [m] of the horizontal plane each point belongs to, NaN
                (or any non-finite value) for "not floor".
            sensor_origin: (3,) camera position in the world [m]; may lie outside the grid.

        Returns:
            What was done (see `UpdateResult`). An empty or all-invalid frame changes nothing.

        Raises:
            InvalidInputError: (ValueError) wrong shapes, data that are not real numbers, or
                a sensor origin that is not finite or beyond ±`mapper.limits.MAX_COORDINATE_M`
                (see `mapper.grid.validate_frame`).
        """
        pts, heights, origin = validate_frame(points, floor_heights, sensor_origin)
        g = self._geometry
        p = self.params
        ox, oy = g.origin_xy_m
        point_cell = np.empty(pts.shape[0], dtype=np.int64)
        geometry_args = (ox, oy, g.z_min_m, g.cell_m, g.layer_m)
        cells = cell_set(len(pts)) if p.discretize_rays else None  # None: not compiled for it
        if self._columns:
            inserted = insert_frame_columns(
                pts,
                origin,
                *geometry_args,
                self._og,
                self._hit_cols,
                self._miss_cols,
                self._range_masks,
                self._update_table,
                point_cell,
                p.free_margin_m,
                float(p.max_range_m),
                bool(p.clear_outside),
                cells,
                p.repeat_ray_columns,
            )
        else:
            inserted = insert_frame(
                pts,
                origin,
                *geometry_args,
                self._og,
                self._mark,
                self._touched,
                self._hit_table,
                self._miss_table,
                point_cell,
                p.free_margin_m,
                float(p.max_range_m),
                bool(p.clear_outside),
                cells,
            )
        used, nonfinite, outside, beyond, cells, ix0, ix1, iy0, iy1 = inserted
        if p.above_top_reach_m > p.delta_m:  # `mapper.above_top`
            if self._above_scratch.shape[0] < pts.shape[0]:
                self._above_scratch = np.empty(pts.shape[0], dtype=np.int64)
            a0, a1, b0, b1 = update_above_top(
                pts,
                origin,
                ox,
                oy,
                g.cell_m,
                g.z_max_m,
                p.delta_m,
                p.above_top_reach_m,
                float(p.max_range_m),
                self._above_top,
                self._above_counts,
                self._above_scratch,
                self._hit_table,
                self._miss_table,
                MIN_HIT_POINTS,
            )
            if a1 > a0:
                self._stale_area = AffectedArea(a0, a1, b0, b1).union(self._stale_area)
        if cells == 0:
            return UpdateResult(None, used, nonfinite, outside, 0, 0, 0, beyond)
        verify_floor(
            self._floor, self._og, self._occ_level, g.z_min_m, g.layer_m, ix0, ix1, iy0, iy1
        )
        frame_verdicts(
            self._floor,
            self._floor_frame_votes,
            point_cell,
            pts[:, 2],
            heights,
            p.eps_m,
            p.floor_frame_cap,
        )
        floor_used, floor_rejected = update_floor(
            self._floor,
            self._floor_weights,
            self._floor_votes,
            self._floor_frame_votes,
            self._og,
            point_cell,
            pts,
            heights,
            origin,
            self._occ_level,
            g.z_min_m,
            g.layer_m,
            p.eps_m,
            p.nu,
            p.floor_vote_cap,
            p.floor_memory,
            p.floor_range_power,
            p.delta_m,
        )
        if p.splits_edges:  # `mapper.floor_edges`
            count_split_frames(
                self._split_frames.reshape(-1),
                self._lower_split_frames.reshape(-1),
                self._multi_frames.reshape(-1),
                *self._split_scratch,
                self._floor.reshape(-1),
                point_cell,
                heights,
                p.edge_split_gap_m,
            )
        if p.floor_pass_fraction > 0.0:
            accumulate_cover(
                self._floor,
                self._cover_ref,
                self._cover_ends,
                self._cover_passes,
                point_cell,
                pts,
                heights,
                origin,
                frame_floor_heights(heights, p.eps_m),
                ox,
                oy,
                g.cell_m,
                p.eps_m,
            )
        # The obstacle heights and the FOG are recomputed when they are read (`_refresh_fog`).
        # With raised rims the FOG is rewritten a cell farther, so that every cell whose
        # neighbour's label may have changed gets its label afresh before the rim rule.
        grow = 1 if p.raised_rim_obstacle or self._confirms_floors else 0
        grown = AffectedArea(
            max(int(ix0) - grow, 0),
            min(int(ix1) + grow, p.nx),
            max(int(iy0) - grow, 0),
            min(int(iy1) + grow, p.ny),
        )
        self._stale_area = grown.union(self._stale_area)
        return UpdateResult(
            AffectedArea(int(ix0), int(ix1), int(iy0), int(iy1)),
            used,
            nonfinite,
            outside,
            floor_used,
            floor_rejected,
            cells,
            beyond,
        )

    def _refresh_fog(self) -> None:
        """Recompute the obstacle heights (eq. 10) and the FOG (eq. 11) where they are stale.

        `update` changes the occupancy, floor and cover maps and only marks the area it
        changed (grown by a cell with raised rims or `MapperParams.min_floor_frames`); the two
        derived maps are recomputed here, once over the bounding box of every area marked
        since, when they are read (`fog`, `obstacle`) and before the grids scroll
        (`recenter`). A cell's label is a function of the maps around it
        (`mapper.fog.update_fog_area`, `mapper.fog.mark_raised_rims`,
        `mapper.fog.mark_unconfirmed_floors`: they never read the labels they wrote before,
        but their own cell's), so the result is bit for bit what
        recomputing them after every update gives (``tests/test_fog_lazy.py``), and a frame
        whose FOG nobody reads costs no FOG (the stage's update: 0.14 of 0.93 ms a frame,
        `bench/bench_mapper.py --stages`). Scrolling first brings them up to date: after a
        scroll the cells beside the entering border would see its unknown cells where the
        update saw the cells that left.
        """
        stale = self._stale_area
        if stale is None:
            return
        self._stale_area = None
        ix0, ix1, iy0, iy1 = stale.ix0, stale.ix1, stale.iy0, stale.iy1
        g = self._geometry
        p = self.params
        update_fog_area(
            self._og,
            self._floor,
            self._obstacle,
            self._fog_types,
            self._fog_heights,
            self._occ_level,
            g.z_min_m,
            g.layer_m,
            p.delta_m,
            ix0,
            ix1,
            iy0,
            iy1,
            self._cover_ends,
            self._cover_passes,
            p.floor_pass_min_rays,
            p.floor_pass_fraction,
            p.obstacle_margin_cells,
            p.edge_band_m,
            p.unknown_beside_obstacles,
            p.narrow_rise_cells,
            p.shadow_reach_cells,
            p.min_floor_neighbours,
            p.rim_over_spill,
            p.rim_over_seen_drop,
            p.ground_noise_unknown,
        )
        ring = self._fog_ring
        if p.raised_rim_obstacle:  # `mapper.fog.mark_raised_rims`
            mark_raised_rims(
                self._floor,
                self._obstacle,
                self._fog_types,
                self._fog_heights,
                p.delta_m,
                ix0 - ring,
                ix1 + ring,
                iy0 - ring,
                iy1 + ring,
            )
        if self._confirms_floors:  # `mapper.fog.mark_unconfirmed_floors`, after every rule
            mark_unconfirmed_floors(
                self._floor,
                self._obstacle,
                self._floor_frame_votes,
                self._fog_types,
                self._fog_heights,
                p.min_floor_frames,
                p.edge_band_m if p.edge_band_m > 0.0 else p.eps_m,
                p.eps_m,
                ix0 - ring,
                ix1 + ring,
                iy0 - ring,
                iy1 + ring,
            )
        if self._marks_edges:  # `mapper.floor_edges`, output only, after every rule above
            mark_floor_edges(
                self._fog_types,
                self._fog_heights,
                self._floor,
                self._floor_frame_votes,
                self._split_frames,
                self._lower_split_frames,
                self._multi_frames,
                self._cover_ends,
                self._cover_passes,
                p.edge_split_share,
                p.edge_split_lower_share,
                p.edge_split_contrast,
                p.weak_foot_frames,
                p.edge_band_m if p.edge_band_m > 0.0 else p.eps_m,
                p.judges_uncovered_rims,
                p.floor_pass_min_rays,
                p.floor_pass_fraction,
                p.eps_m,
                p.narrow_rise_cells,
                ix0 - ring,
                ix1 + ring,
                iy0 - ring,
                iy1 + ring,
            )
        if p.above_top_reach_m > p.delta_m:  # `mapper.above_top`, over every other rule
            # The window the rules above rewrote (the stale area and its ring): a column whose
            # level changed lies in the stale area; the others already carry it.
            window = (
                slice(max(ix0 - ring, 0), min(ix1 + ring, p.nx)),
                slice(max(iy0 - ring, 0), min(iy1 + ring, p.ny)),
            )
            rises = self._above_top[window] > self._occ_level
            self._fog_types[window][rises] = CellType.OBSTACLE
            self._fog_heights[window][rises] = g.z_max_m

    # ------------------------------------------------------------------ read-out
    def occupancy(self) -> NDArray[np.float64]:
        """(nx, ny, nz) occupancy probabilities (level / 256), a copy."""
        return self._og / float(LEVELS)

    def occupancy_levels(self) -> NDArray[np.uint8]:
        """(nx, ny, nz) raw 8-bit levels (probability = level / 256), a copy."""
        return self._og.copy()

    def floor(self) -> NDArray[np.float64]:
        """(nx, ny) floor heights [m], NaN where invalid (a copy)."""
        return self._floor.copy()

    def obstacle(self) -> NDArray[np.float64]:
        """(nx, ny) coarse obstacle heights (eq. 10: top of highest occupied cell) [m], NaN."""
        self._refresh_fog()
        return self._obstacle.copy()

    def ceiling(self) -> NDArray[np.float64]:
        """(nx, ny) ceiling heights [m], NaN where none.

        The bottom of the lowest occupied cell above the free space (see `mapper.fog`).
        """
        g = self._geometry
        return ceiling_map(
            self._og, self._floor, self._occ_level, g.z_min_m, g.layer_m, self.params.delta_m
        )

    def fog(self) -> tuple[NDArray[np.int8], NDArray[np.float64]]:
        """The FOG (eq. 11): (types (nx, ny) int8 `CellType` values, heights [m] NaN=unknown)."""
        self._refresh_fog()
        return self._fog_types.copy(), self._fog_heights.copy()

    def floor_at(self, x_m: float, y_m: float) -> float:
        """Floor height [m] of the cell holding world (x, y); NaN if invalid or off the grid.

        The cell of :meth:`GridGeometry.cell_of` (the same arithmetic on one point, without
        its arrays: a cell index floor(v) lies in [0, n) exactly when v does, NaN nowhere).
        """
        g = self._geometry
        ox, oy = g.origin_xy_m
        vx = (real_scalar(x_m, "x_m") - ox) / g.cell_m
        vy = (real_scalar(y_m, "y_m") - oy) / g.cell_m
        if not (0.0 <= vx < g.nx and 0.0 <= vy < g.ny):
            return float("nan")
        return float(self._floor[int(vx), int(vy)])

    # ------------------------------------------------------------------ z matching
    def match_z(self, points: ArrayLike, floor_heights: ArrayLike) -> ZMatch:
        """The z shift (Sec. IV) of this frame's floor points onto the floor map (`mapper.zmatch`).

        Args:
            points: (N, 3) world points [m].
            floor_heights: (N,) floor heights [m], NaN = not floor.
        """
        pts, heights, _ = validate_frame(points, floor_heights, np.zeros(3))
        return match_z(pts, heights, self._floor, self._geometry, self.params)

    # ------------------------------------------------------------------ scrolling
    def recenter(self, x_m: float, y_m: float) -> tuple[int, int]:
        """Scroll all grids by whole cells so world (x, y) lies in the central cell.

        Entering cells start unknown (0.5, invalid floor). Cost: one copy of each grid at
        most, independent of the distance moved.

        Returns:
            The shift (sx, sy) in cells that was applied (0, 0 if none was needed).

        Raises:
            InvalidInputError: ``x_m`` or ``y_m`` is not a finite coordinate within
                ±`mapper.limits.MAX_COORDINATE_M` (the maps are left as they were).
        """
        sx, sy = self._geometry.shift_to(x_m, y_m)
        if sx == 0 and sy == 0:
            return (0, 0)
        self._refresh_fog()
        scroll_xy(self._og, sx, sy, LEVEL_UNKNOWN)
        scroll_xy(self._floor, sx, sy, np.nan)
        scroll_xy(self._floor_weights, sx, sy, 0.0)
        scroll_xy(self._floor_votes, sx, sy, 0)
        scroll_xy(self._floor_frame_votes, sx, sy, 0)
        scroll_xy(self._split_frames, sx, sy, 0)
        scroll_xy(self._lower_split_frames, sx, sy, 0)
        scroll_xy(self._multi_frames, sx, sy, 0)
        scroll_xy(self._cover_ref, sx, sy, np.nan)
        scroll_xy(self._cover_ends, sx, sy, 0)
        scroll_xy(self._cover_passes, sx, sy, 0)
        scroll_xy(self._obstacle, sx, sy, np.nan)
        scroll_xy(self._fog_types, sx, sy, CellType.UNKNOWN)
        scroll_xy(self._fog_heights, sx, sy, np.nan)
        scroll_xy(self._above_top, sx, sy, LEVEL_UNKNOWN)
        self._geometry = self._geometry.shifted(sx, sy)
        return (sx, sy)
