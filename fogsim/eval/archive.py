"""The world-fixed archive of a run's maps: the last value of every map in every cell.

The mapper's grids follow the robot and scroll by whole cells, so a run is scored on a
:class:`WorldArchive`: a world-fixed lattice of the mapper's cells that keeps, for every cell
that was ever inside the map, the last FOG, floor, obstacle, ceiling and averaging-baseline value
it had there, and whether the camera ever saw it (:func:`cells_in_view`). Arrays are indexed
``[ix, iy]`` over the lattice, heights in metres in the world frame, NaN = none.

Memory: the archive spans the bounding box of every grid stored. Its storage grows
geometrically (each growth at least doubles the side that grew, so a walk of n cells copies the
archive O(log n) times, not n times) and is bounded by :data:`MAX_ARCHIVE_CELLS`: a grid that
would take the bounding box beyond it raises :class:`ArchiveExtentError` before anything is
allocated. The pipeline refuses implausible pose jumps first
(:data:`fogsim.data.limits.MAX_POSE_STEP_M`), so only a long walk reaches the bound.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from fogsim.data.frame import Frame
from fogsim.errors import ArchiveExtentError, FogsimError
from mapper import CellType
from mapper.grid import GridGeometry
from mapper.transforms import apply_transform

MAX_ARCHIVE_CELLS = 1 << 22
"""Cells the archive's bounding box may span (storage included): 4 194 304, e.g. 82 m × 82 m of
the default 4 cm cells or a 330 m × 20 m corridor, 214 times the largest shipped scenario's
archive (the stage: 194 × 101 cells). Its eight layers take 43 bytes a cell: 180 MB at most."""

_LAYERS = (
    ("fog_types", np.int8, CellType.UNKNOWN),
    ("fog_heights_m", np.float64, np.nan),
    ("floor_m", np.float64, np.nan),
    ("obstacle_m", np.float64, np.nan),
    ("ceiling_m", np.float64, np.nan),
    ("baseline_heights_m", np.float64, np.nan),
    ("visited", np.bool_, False),
    ("in_view", np.bool_, False),
)
"""The archive's layers: name, element type and the value of a cell never stored."""


InView = Callable[..., NDArray[np.bool_]]
"""``(frame, geometry, points_world=None) -> (nx, ny) bool``: :func:`cells_in_view`, or a cache
in front of it (``fogsim tune``: :class:`~fogsim.tune.segment_cache.ViewCache`). Its result is
only read."""


def cells_in_view(
    frame: Frame, geometry: GridGeometry, points_world: NDArray[np.float64] | None = None
) -> NDArray[np.bool_]:
    """(nx, ny) cells of a grid that the frame's camera saw.

    A cell is in view when a depth measurement of the frame, placed in the world with the
    *true* camera pose, lies in one of the cell's layers (inside the grid's height range: what
    lies above or below it cannot be mapped). Pixels without a measurement (NaN: dropouts, out
    of range, the robot's own body) see nothing; a frame without a true pose (real data, NaN)
    sees no cell.

    Args:
        frame: The frame.
        geometry: The grid.
        points_world: The frame's :func:`view_points_world` if made already (a run makes them
            on its segmentation thread, ahead of the mapping); None: made here.
    """
    if points_world is None:
        points_world = view_points_world(frame)
    return geometry.columns_seen(points_world)


def view_points_world(frame: Frame) -> NDArray[np.float64]:
    """(N, 3) the frame's depth measurements in the world by its *true* camera pose [m].

    One row per pixel, NaN where there is no measurement (or no true pose): what
    :func:`cells_in_view` places in a grid. Depends on the frame only.
    """
    points_camera = frame.intrinsics.depth_to_points_camera(frame.depth_m).reshape(-1, 3)
    return apply_transform(frame.transform_camera_to_world_true, points_camera)


class _Layer:
    """A layer of the archive read as an attribute (:meth:`WorldArchive.layer`)."""

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name

    def __get__(self, archive: WorldArchive, owner: type | None = None) -> NDArray[Any]:
        return archive.layer(self.name)


class WorldArchive:
    """World-fixed lattice of the mapper's cells: the last value of each map in each cell.

    The lattice is anchored at the first grid's cell centres; the mapper scrolls by whole cells,
    so every later grid lies on it. The archive spans the bounding box of all grids stored; its
    storage grows geometrically and is bounded by :data:`MAX_ARCHIVE_CELLS` (see the module).

    Attributes (each (nx, ny) over the bounding box, C-contiguous and read-only):
        cell_m: Cell side [m].
        fog_types: Last FOG label (``mapper.CellType``), UNKNOWN where never in a map.
        fog_heights_m: Last FOG height [m] (floor height or coarse obstacle top).
        floor_m: Last floor height of the floor map [m].
        obstacle_m: Last coarse obstacle height (eq. 10) [m].
        ceiling_m: Last ceiling height (the paper's extension) [m].
        baseline_heights_m: Last averaging-baseline height [m].
        visited: The cell was inside the map in some frame (the scored region).
        in_view: The camera saw the cell in some frame (:func:`cells_in_view`).
    """

    fog_types = _Layer()
    fog_heights_m = _Layer()
    floor_m = _Layer()
    obstacle_m = _Layer()
    ceiling_m = _Layer()
    baseline_heights_m = _Layer()
    visited = _Layer()
    in_view = _Layer()

    def __init__(self, cell_m: float) -> None:
        self.cell_m = float(cell_m)
        self._anchor_xy: NDArray[np.float64] | None = None
        self._lo = np.zeros(2, dtype=np.int64)  # lattice index of archive cell [0, 0]
        self._shape = np.zeros(2, dtype=np.int64)  # the bounding box's (nx, ny)
        self._storage_lo = np.zeros(2, dtype=np.int64)  # lattice index of storage cell [0, 0]
        self._storage = {name: np.full((0, 0), fill, dtype) for name, dtype, fill in _LAYERS}

    def layer(self, name: str) -> NDArray[np.generic]:
        """Layer ``name`` over the bounding box, C-contiguous and read-only.

        Contiguous as a plain array of the box would be, so reductions over it add in the same
        order; a view of the storage when the storage is the box, else a copy.
        """
        ox, oy = (int(v) for v in self._lo - self._storage_lo)
        nx, ny = (int(v) for v in self._shape)
        layer = np.ascontiguousarray(self._storage[name][ox : ox + nx, oy : oy + ny])
        layer.flags.writeable = False
        return layer

    @property
    def storage_cells(self) -> int:
        """Cells allocated for each layer (the bounding box and room to grow)."""
        return int(self._storage["visited"].size)

    def _anchor(self) -> NDArray[np.float64]:
        """World centre [m] of lattice cell (0, 0): the first stored grid's first cell."""
        if self._anchor_xy is None:
            raise FogsimError("the world archive is empty: store a map before asking for cells")
        return self._anchor_xy

    def lattice_index(self, points_xy: NDArray[np.floating]) -> NDArray[np.int64]:
        """Lattice index (…, 2) of world points (…, 2) [m] (nearest cell centre)."""
        return np.rint((np.asarray(points_xy) - self._anchor()) / self.cell_m).astype(np.int64)

    def _grow(self, lo: NDArray[np.int64], hi: NDArray[np.int64]) -> None:
        """Extend the bounding box to hold lattice cells [lo, hi); grow the storage if needed.

        Raises:
            ArchiveExtentError: The box would span more than :data:`MAX_ARCHIVE_CELLS` cells.
        """
        empty = not self._shape.all()
        new_lo = lo if empty else np.minimum(self._lo, lo)
        new_hi = hi if empty else np.maximum(self._lo + self._shape, hi)
        shape = new_hi - new_lo
        if int(shape[0]) * int(shape[1]) > MAX_ARCHIVE_CELLS:
            nx, ny = (int(v) for v in shape)
            raise ArchiveExtentError(
                f"storing a grid at lattice cells {lo.tolist()} to {hi.tolist()} would make the "
                f"world archive span {nx} × {ny} cells ({nx * self.cell_m:.1f} m × "
                f"{ny * self.cell_m:.1f} m); at most {MAX_ARCHIVE_CELLS} cells "
                "(MAX_ARCHIVE_CELLS): the run covers more ground than one archive holds"
            )
        storage_shape = np.array(self._storage["visited"].shape, dtype=np.int64)
        storage_hi = self._storage_lo + storage_shape
        if empty or np.any(new_lo < self._storage_lo) or np.any(new_hi > storage_hi):
            self._reallocate(new_lo, new_hi, storage_shape, empty)
        self._lo, self._shape = new_lo, shape

    def _reallocate(
        self,
        lo: NDArray[np.int64],
        hi: NDArray[np.int64],
        storage_shape: NDArray[np.int64],
        empty: bool,
    ) -> None:
        """New storage for lattice cells [lo, hi) with room to grow; the old box copied in.

        Each side that grew gets as many cells again as the storage had along it (amortised
        growth: the next growths need no copy), unless that would pass
        :data:`MAX_ARCHIVE_CELLS`; the first grid gets exactly its cells.
        """
        shape = hi - lo
        grew_low = empty | (lo < self._storage_lo)
        grew_high = empty | (hi > self._storage_lo + storage_shape)
        grown = (grew_low | grew_high) & ~empty
        size = np.maximum(shape, np.where(grown, 2 * storage_shape, storage_shape))
        if empty or int(size[0]) * int(size[1]) > MAX_ARCHIVE_CELLS:
            size = shape
        spare = size - shape
        storage_lo = lo - np.where(grew_low & grew_high, spare // 2, np.where(grew_low, spare, 0))
        old_x, old_y = (int(v) for v in self._lo - self._storage_lo)
        new_x, new_y = (int(v) for v in self._lo - storage_lo)
        nx, ny = (int(v) for v in self._shape)
        for name, dtype, fill in _LAYERS:
            new = np.full(tuple(int(v) for v in size), fill, dtype=dtype)
            new[new_x : new_x + nx, new_y : new_y + ny] = self._storage[name][
                old_x : old_x + nx, old_y : old_y + ny
            ]
            self._storage[name] = new
        self._storage_lo = storage_lo

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
        :func:`cells_in_view`) is added to the cells seen before. The same as
        :meth:`store_grid` with the first cell's centre.

        Raises:
            ArchiveExtentError: The archive would span more than :data:`MAX_ARCHIVE_CELLS`.
        """
        centers = np.asarray(cell_centers_xy, dtype=np.float64)
        if centers.shape != (*np.shape(fog_types), 2):
            raise FogsimError(
                f"cell centres of shape {centers.shape} for maps of shape {np.shape(fog_types)}"
            )
        self.store_grid(
            centers[0, 0],
            fog_types,
            fog_heights_m,
            baseline_heights_m,
            floor_m=floor_m,
            obstacle_m=obstacle_m,
            ceiling_m=ceiling_m,
            in_view=in_view,
        )

    def store_grid(
        self,
        corner_xy: NDArray[np.floating],
        fog_types: NDArray[np.integer],
        fog_heights_m: NDArray[np.floating],
        baseline_heights_m: NDArray[np.floating],
        *,
        floor_m: NDArray[np.floating],
        obstacle_m: NDArray[np.floating],
        ceiling_m: NDArray[np.floating],
        in_view: NDArray[np.bool_],
    ) -> None:
        """:meth:`store` given the centre (2,) [m] of the grid's cell [0, 0] only.

        The grid is the maps' (nx, ny): a run need not build every cell's centre each frame
        (:meth:`~mapper.grid.GridGeometry.cell_center` of (0, 0) is that of the full array).

        Raises:
            ArchiveExtentError: The archive would span more than :data:`MAX_ARCHIVE_CELLS`.
        """
        corner_xy = np.asarray(corner_xy, dtype=np.float64)
        if self._anchor_xy is None:
            self._anchor_xy = corner_xy.copy()
        corner = self.lattice_index(corner_xy)
        nx, ny = np.shape(fog_types)
        self._grow(corner, corner + np.array([nx, ny]))
        ox, oy = (int(v) for v in corner - self._storage_lo)
        sl = (slice(ox, ox + nx), slice(oy, oy + ny))
        layers = self._storage
        layers["fog_types"][sl] = fog_types
        layers["fog_heights_m"][sl] = fog_heights_m
        layers["floor_m"][sl] = floor_m
        layers["obstacle_m"][sl] = obstacle_m
        layers["ceiling_m"][sl] = ceiling_m
        layers["baseline_heights_m"][sl] = baseline_heights_m
        layers["visited"][sl] = True
        layers["in_view"][sl] |= np.asarray(in_view, dtype=bool)

    def is_empty(self) -> bool:
        """The FOG labelled no cell floor or obstacle (or nothing was stored)."""
        return not bool((self.visited & (self.fog_types != CellType.UNKNOWN)).any())

    def cell_centers_xy(self) -> NDArray[np.float64]:
        """(nx, ny, 2) world centres [m] of the archive's cells."""
        anchor_xy = self._anchor()
        ix = np.arange(self._shape[0]) + self._lo[0]
        iy = np.arange(self._shape[1]) + self._lo[1]
        gx, gy = np.meshgrid(ix, iy, indexing="ij")
        return anchor_xy + self.cell_m * np.stack([gx, gy], axis=-1)
