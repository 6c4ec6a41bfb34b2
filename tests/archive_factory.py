"""Hand-built archives and truth grids for scoring tests with known answers."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from fogsim.eval.archive import WorldArchive
from fogsim.world.truth import GroundTruthGrid
from mapper.grid import CellType

CELL = 0.04
FLOOR, OBSTACLE, UNKNOWN = CellType.FLOOR, CellType.OBSTACLE, CellType.UNKNOWN


def centers(nx: int = 30, ny: int = 30, x0: float = 0.0, y0: float = 0.0) -> NDArray[np.float64]:
    """(nx, ny, 2) centres of cells of side CELL whose corner is (x0, y0)."""
    ix, iy = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    return np.stack([x0 + (ix + 0.5) * CELL, y0 + (iy + 0.5) * CELL], axis=-1)


def store(
    archive: WorldArchive,
    cell_centers: NDArray[np.float64],
    fog_types: NDArray[np.integer],
    fog_heights_m: NDArray[np.floating],
    baseline_heights_m: NDArray[np.floating] | None = None,
    *,
    ceiling_m: NDArray[np.floating] | None = None,
    in_view: NDArray[np.bool_] | None = None,
) -> WorldArchive:
    """Store one grid of maps: floor = the FOG's floor heights, obstacle = its obstacle heights,
    no ceiling and every cell in view unless given; the baseline defaults to the FOG heights."""
    types = np.asarray(fog_types, dtype=np.int8)
    heights = np.asarray(fog_heights_m, dtype=np.float64)
    shape = types.shape
    archive.store(
        cell_centers,
        types,
        heights,
        heights if baseline_heights_m is None else baseline_heights_m,
        floor_m=np.where(types == FLOOR, heights, np.nan),
        obstacle_m=np.where(types == OBSTACLE, heights, np.nan),
        ceiling_m=np.full(shape, np.nan) if ceiling_m is None else ceiling_m,
        in_view=np.ones(shape, dtype=bool) if in_view is None else in_view,
    )
    return archive


def truth_grid(
    labels: NDArray[np.integer],
    floor_m: NDArray[np.floating],
    obstacle_top_m: NDArray[np.floating] | None = None,
    *,
    ceiling_m: NDArray[np.floating] | None = None,
    object_id: NDArray[np.integer] | None = None,
    object_names: tuple[str, ...] = (),
) -> GroundTruthGrid:
    """A hand-built truth: every cell interior ground-surface floor or obstacle as labelled."""
    labels = np.asarray(labels, dtype=np.int8)
    shape = labels.shape
    floor = np.where(labels == FLOOR, np.asarray(floor_m, dtype=np.float64), np.nan)
    tops = np.full(shape, np.nan) if obstacle_top_m is None else np.asarray(obstacle_top_m)
    return GroundTruthGrid(
        floor_m=floor,
        obstacle_top_m=np.where(labels == OBSTACLE, tops, np.nan),
        labels=labels,
        surface_id=np.where(labels == FLOOR, 0, -1).astype(np.int32),
        interior=np.ones(shape, dtype=bool),
        surface_names=("ground",),
        surface_heights_m={"ground": 0.0},
        cell_m=CELL,
        ceiling_m=np.full(shape, np.nan) if ceiling_m is None else np.asarray(ceiling_m),
        object_id=(
            np.full(shape, -1, dtype=np.int32)
            if object_id is None
            else np.asarray(object_id, dtype=np.int32)
        ),
        object_names=object_names,
    )
