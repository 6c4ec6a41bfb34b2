"""Grid geometry and the small types every map shares (cell labels, affected area, update result).

Cell convention (world frame, metres): cell ``(ix, iy, iz)`` covers
``origin_x + ix·cell_m <= x < origin_x + (ix+1)·cell_m`` (same in y) and
``z_min_m + iz·layer_m <= z < z_min_m + (iz+1)·layer_m``. The x/y origin is always a whole
multiple of ``cell_m`` (cell boundaries are world-anchored at ``k·cell_m``) and moves in whole
cells when the maps are recentred; z is absolute and never moves.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from mapper.errors import InvalidInputError
from mapper.limits import MAX_COORDINATE_M
from mapper.params import MapperParams
from mapper.validation import coordinate_m, real_array


class CellType(IntEnum):
    """Label of a FOG cell (eq. 11); also the labels of ground-truth grids."""

    UNKNOWN = 0
    FLOOR = 1
    OBSTACLE = 2


@dataclass(frozen=True)
class GridGeometry:
    """Where the grid lies in the world.

    Attributes:
        nx: Cells along x.
        ny: Cells along y.
        nz: Layers along z.
        cell_m: Cell side in x and y [m].
        layer_m: Layer height [m].
        z_min_m: World z of the lowest layer's bottom face [m].
        origin_ix: World lattice index of the grid's corner cell along x: the corner (lowest
            x, y) is at ``origin_ix·cell_m``. Integer so that recentring never drifts.
        origin_iy: Same along y.
    """

    nx: int
    ny: int
    nz: int
    cell_m: float
    layer_m: float
    z_min_m: float
    origin_ix: int = 0
    origin_iy: int = 0

    @classmethod
    def from_params(cls, params: MapperParams, center_xy_m: ArrayLike = (0.0, 0.0)) -> GridGeometry:
        """Geometry of ``params``' grid placed so that ``center_xy_m`` lies in the central cell.

        The central cell is ``(nx // 2, ny // 2)``.

        Raises:
            InvalidInputError: ``center_xy_m`` is not two finite coordinates within
                ±`mapper.limits.MAX_COORDINATE_M`.
        """
        center = real_array(center_xy_m, "center_xy_m")
        if center.shape != (2,):
            raise InvalidInputError(f"center_xy_m must have shape (2,) [m], got {center.shape}")
        cx, cy = (coordinate_m(v, "center_xy_m") for v in center)
        return cls(
            params.nx,
            params.ny,
            params.nz,
            params.cell_m,
            params.layer_m,
            params.z_min_m,
            math.floor(cx / params.cell_m) - params.nx // 2,
            math.floor(cy / params.cell_m) - params.ny // 2,
        )

    @property
    def origin_xy_m(self) -> tuple[float, float]:
        """World (x, y) of the grid's corner (lowest x and y) [m]."""
        return (self.origin_ix * self.cell_m, self.origin_iy * self.cell_m)

    @property
    def z_max_m(self) -> float:
        """World z of the top layer's upper face [m]."""
        return self.z_min_m + self.nz * self.layer_m

    def shift_to(self, x_m: float, y_m: float) -> tuple[int, int]:
        """Whole-cell shift (sx, sy) that puts world (x, y) into the central cell.

        Raises:
            InvalidInputError: ``x_m`` or ``y_m`` is not a finite coordinate within
                ±`mapper.limits.MAX_COORDINATE_M` (NaN, inf or 1e300 would otherwise fail
                without a name or scroll every cell out of the map).
        """
        x_m = coordinate_m(x_m, "x_m")
        y_m = coordinate_m(y_m, "y_m")
        return (
            math.floor(x_m / self.cell_m) - self.nx // 2 - self.origin_ix,
            math.floor(y_m / self.cell_m) - self.ny // 2 - self.origin_iy,
        )

    def shifted(self, sx: int, sy: int) -> GridGeometry:
        """This geometry moved by (sx, sy) whole cells."""
        return GridGeometry(
            self.nx,
            self.ny,
            self.nz,
            self.cell_m,
            self.layer_m,
            self.z_min_m,
            self.origin_ix + sx,
            self.origin_iy + sy,
        )

    def cell_of(self, points_world: ArrayLike) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
        """Cell indices of world points.

        Args:
            points_world: (N, 3) world points [m] (or (N, 2) for x, y only).

        Returns:
            (indices (N, 3) or (N, 2) int64, valid (N,) bool: finite and inside the grid).
            Indices of invalid points are -1.
        """
        p = real_array(points_world, "points_world")
        if p.ndim != 2 or p.shape[1] not in (2, 3):
            raise InvalidInputError(f"points_world must have shape (N, 3) or (N, 2), got {p.shape}")
        idx = np.empty(p.shape, dtype=np.int64)
        valid = np.ones(p.shape[0], dtype=bool)
        with np.errstate(invalid="ignore"):  # NaN and inf fail the tests; their casts are junk
            for axis in range(p.shape[1]):  # per axis, not per point
                cells, inside = self._axis_cells(p, axis)
                valid &= inside
                idx[:, axis] = cells
        idx[~valid] = -1
        return idx, valid

    def columns_seen(self, points_world: ArrayLike) -> NDArray[np.bool_]:
        """(nx, ny) columns holding at least one of the points inside the grid volume.

        The columns of the valid cells of :meth:`cell_of` (a point in a column but above or
        below the grid's layers marks nothing), in one compiled pass without its index arrays:
        the same cells bit for bit (``tests/test_exact_fast_paths.py``), in a tenth of its
        time.

        Args:
            points_world: (N, 3) world points [m]; NaN rows mark nothing.
        """
        p = real_array(points_world, "points_world")
        if p.ndim != 2 or p.shape[1] != 3:
            raise InvalidInputError(f"points_world must have shape (N, 3), got {p.shape}")
        ox, oy = self.origin_xy_m
        seen = np.zeros(self.nx * self.ny, dtype=bool)
        _mark_columns(
            np.ascontiguousarray(p, dtype=np.float64),
            float(ox),
            float(oy),
            float(self.z_min_m),
            float(self.cell_m),
            float(self.layer_m),
            self.nx,
            self.ny,
            self.nz,
            seen,
        )
        return seen.reshape(self.nx, self.ny)

    def _axis_cells(
        self, points_world: NDArray[np.float64], axis: int
    ) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
        """Cell index along ``axis`` (0: x, 1: y, 2: z) of (N, k) points, as floats; inside.

        Call under ``np.errstate(invalid="ignore")``: NaN coordinates give NaN, outside.
        """
        ox, oy = self.origin_xy_m
        lowest = (ox, oy, self.z_min_m)[axis]
        size = (self.cell_m, self.cell_m, self.layer_m)[axis]
        cells = np.floor((points_world[:, axis] - lowest) / size)
        return cells, (cells >= 0) & (cells < (self.nx, self.ny, self.nz)[axis])

    def cell_center(
        self, ix: ArrayLike, iy: ArrayLike, iz: ArrayLike | None = None
    ) -> NDArray[np.float64]:
        """World centre [m] of cells: (..., 2) for (ix, iy), (..., 3) when ``iz`` is given."""
        ox, oy = self.origin_xy_m
        x = ox + (real_array(ix, "ix") + 0.5) * self.cell_m
        y = oy + (real_array(iy, "iy") + 0.5) * self.cell_m
        if iz is None:
            return np.stack(np.broadcast_arrays(x, y), axis=-1)
        z = self.z_min_m + (real_array(iz, "iz") + 0.5) * self.layer_m
        return np.stack(np.broadcast_arrays(x, y, z), axis=-1)

    def cell_centers_xy(self) -> NDArray[np.float64]:
        """(nx, ny, 2) world (x, y) of every cell centre [m]."""
        ix, iy = np.meshgrid(np.arange(self.nx), np.arange(self.ny), indexing="ij")
        return self.cell_center(ix, iy)

    def layer_bottom_m(self, iz: ArrayLike) -> NDArray[np.float64]:
        """World z [m] of the bottom face of layer(s) ``iz``."""
        return self.z_min_m + real_array(iz, "iz") * self.layer_m


@dataclass(frozen=True)
class AffectedArea:
    """Bounding box of the (x, y) cells an update changed, half-open ``[ix0, ix1) × [iy0, iy1)``."""

    ix0: int
    ix1: int
    iy0: int
    iy1: int

    @property
    def slices(self) -> tuple[slice, slice]:
        """Index the (nx, ny) maps with these to get the area."""
        return (slice(self.ix0, self.ix1), slice(self.iy0, self.iy1))

    @property
    def cell_count(self) -> int:
        """Columns in the area."""
        return (self.ix1 - self.ix0) * (self.iy1 - self.iy0)

    def union(self, other: AffectedArea | None) -> AffectedArea:
        """The bounding box of both areas (this one when ``other`` is None)."""
        if other is None:
            return self
        return AffectedArea(
            min(self.ix0, other.ix0),
            max(self.ix1, other.ix1),
            min(self.iy0, other.iy0),
            max(self.iy1, other.iy1),
        )


@dataclass(frozen=True)
class UpdateResult:
    """What one ``update`` did.

    Attributes:
        affected_area: Columns whose 3D cells changed (steps 2–4 ran only there), None if none.
        points_used: Points inserted (finite and inside the grid).
        points_dropped_nonfinite: Points with a NaN/inf coordinate, or one beyond
            ±`mapper.limits.MAX_COORDINATE_M`, ignored.
        points_dropped_outside: Finite points (within ``max_range_m``) outside the grid in x,
            y or z: no hit, but with ``MapperParams.clear_outside`` their rays still clear the
            cells they cross inside the grid.
        floor_points_used: Floor-labelled points that passed eq. 7 and updated the floor map.
        floor_points_rejected: Floor-labelled points that failed eq. 7 (cell at ``h`` not
            occupied, or ``h`` outside the grid's z range).
        cells_updated: 3D cells that received a (hit or miss) update this frame.
        points_beyond_range: Finite points farther than ``MapperParams.max_range_m`` from the
            sensor (inside the grid or not): no hit, their rays clear up to that range.
    """

    affected_area: AffectedArea | None
    points_used: int
    points_dropped_nonfinite: int
    points_dropped_outside: int
    floor_points_used: int
    floor_points_rejected: int
    cells_updated: int = 0
    points_beyond_range: int = 0


def validate_frame(
    points: ArrayLike, floor_heights: ArrayLike, sensor_origin: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Check and convert the inputs of ``update`` (C-contiguous float64).

    Rows of ``points`` with a coordinate beyond ±`mapper.limits.MAX_COORDINATE_M` become NaN
    rows (dropped and counted as non-finite), floor heights beyond it NaN ("not floor"): the
    kernels cast coordinates to cell indices, which such values would overflow. The caller's
    arrays are never changed (a copy is made when a row must be replaced).

    Raises:
        InvalidInputError: (a ValueError) naming the expected shape, data that are not real
            numbers (complex, bool, strings), or a sensor origin that is not finite or beyond
            the coordinate limit.
    """
    p = np.ascontiguousarray(real_array(points, "points"))
    if p.ndim != 2 or p.shape[1] != 3:
        raise InvalidInputError(f"points must have shape (N, 3) [m, world frame], got {p.shape}")
    h = np.ascontiguousarray(real_array(floor_heights, "floor_heights"))
    if h.shape != (p.shape[0],):
        raise InvalidInputError(
            f"floor_heights must have shape (N,) = ({p.shape[0]},) matching points, got {h.shape}"
        )
    o = np.ascontiguousarray(real_array(sensor_origin, "sensor_origin"))
    if o.shape != (3,):
        raise InvalidInputError(f"sensor_origin must have shape (3,), got {o.shape}")
    # One compiled pass first: a frame's numpy reductions and tests cost ~10 times more (small
    # calls' overhead), and the per-row work is needed only when a value is off the limit.
    origin_far, points_off, heights_far = _off_limit(o, p.reshape(-1), h, MAX_COORDINATE_M)
    if origin_far:
        raise InvalidInputError(
            f"sensor_origin must be finite and within ±{MAX_COORDINATE_M:g} m "
            f"(mapper.limits.MAX_COORDINATE_M), got {o.tolist()}"
        )
    if points_off:
        far_rows = np.any(np.abs(p) > MAX_COORDINATE_M, axis=1)  # inf too; NaN is dropped anyway
        if far_rows.any():
            p = p.copy()
            p[far_rows] = np.nan
    if heights_far:
        h = h.copy()
        h[np.abs(h) > MAX_COORDINATE_M] = np.nan
    return p, h, o


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _mark_columns(points, ox, oy, z_min, cell, layer, nx, ny, nz, seen):
    """Set ``seen[ix * ny + iy]`` for each (N, 3) point inside the grid volume (numba).

    A cell index g = floor(v) lies in [0, n) exactly when v does (n whole; NaN in neither):
    the tests need no floor, and inside it is the truncation to an integer. ``v`` is
    ``(coordinate - grid start) / cell size``, as numpy computes it for `GridGeometry.cell_of`.
    """
    for i in range(points.shape[0]):
        vx = (points[i, 0] - ox) / cell
        vy = (points[i, 1] - oy) / cell
        vz = (points[i, 2] - z_min) / layer
        if vx >= 0.0 and vx < nx and vy >= 0.0 and vy < ny and vz >= 0.0 and vz < nz:
            seen[np.int64(vx) * ny + np.int64(vy)] = True


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _off_limit(origin, points, heights, limit):
    """Whether the origin, a point coordinate or a floor height is off ``±limit``, one pass.

    Returns:
        (an origin coordinate is not within ±limit (NaN too), a point coordinate is not within
        ±limit (NaN too), a height is beyond ±limit (NaN not)). Counted as sums of comparisons,
        which compile to vector instructions (an ``or`` of them does not).
    """
    within = 0
    for i in range(origin.shape[0]):
        within += abs(origin[i]) <= limit
    origin_far = within != origin.shape[0]
    within = 0
    for i in range(points.shape[0]):
        within += abs(points[i]) <= limit
    points_off = within != points.shape[0]
    beyond = 0
    for i in range(heights.shape[0]):
        beyond += abs(heights[i]) > limit
    return origin_far, points_off, beyond > 0


def scroll_xy(array: NDArray, sx: int, sy: int, fill: float | int) -> None:
    """Scroll an (nx, ny, ...) array in place by whole cells: ``new[i, j] = old[i + sx, j + sy]``.

    Cells entering the array get ``fill``. Cost is one copy of the array at most, whatever the
    shift (no allocation beyond numpy's overlap buffer).
    """
    nx, ny = array.shape[:2]
    if abs(sx) >= nx or abs(sy) >= ny:
        array[...] = fill
        return
    if sx or sy:
        dst_x = slice(max(0, -sx), nx - max(0, sx))
        src_x = slice(max(0, sx), nx - max(0, -sx))
        dst_y = slice(max(0, -sy), ny - max(0, sy))
        src_y = slice(max(0, sy), ny - max(0, -sy))
        array[dst_x, dst_y] = array[src_x, src_y]
    if sx > 0:
        array[nx - sx :] = fill
    elif sx < 0:
        array[:-sx] = fill
    if sy > 0:
        array[:, ny - sy :] = fill
    elif sy < 0:
        array[:, :-sy] = fill
