"""The world archive: same values as a cell-by-cell model, amortised growth, bounded memory."""

import itertools
import tracemalloc

import numpy as np
import pytest
from archive_factory import CELL, centers, store

from fogsim.eval.archive import ArchiveExtentError, WorldArchive

LAYERS = ("fog_types", "fog_heights_m", "floor_m", "obstacle_m", "ceiling_m", "baseline_heights_m")
BYTES_PER_CELL = 1 + 5 * 8 + 2  # int8 FOG type, five float64 heights, two bools


def _grid_values(rng, shape):
    types = rng.integers(0, 3, shape).astype(np.int8)
    heights = rng.uniform(-0.1, 0.5, shape)
    in_view = rng.random(shape) < 0.5
    return types, heights, in_view


def _model(stores):
    """The archive by its definition: per lattice cell, the last value stored there."""
    cells = {}
    for (ix0, iy0), types, heights, in_view in stores:
        for (i, j), label in np.ndenumerate(types):
            key = (ix0 + i, iy0 + j)
            seen = cells.get(key, {}).get("in_view", False)
            h = heights[i, j]
            cells[key] = {
                "fog_types": label,
                "fog_heights_m": h,
                "floor_m": h if label == 1 else np.nan,
                "obstacle_m": h if label == 2 else np.nan,
                "ceiling_m": np.nan,
                "baseline_heights_m": h,
                "in_view": seen or bool(in_view[i, j]),
            }
    xs = [k[0] for k in cells]
    ys = [k[1] for k in cells]
    lo = (min(xs), min(ys))
    shape = (max(xs) - lo[0] + 1, max(ys) - lo[1] + 1)
    dense = {name: np.full(shape, np.nan) for name in LAYERS}
    dense["fog_types"] = np.zeros(shape, dtype=np.int8)
    dense["visited"] = np.zeros(shape, dtype=bool)
    dense["in_view"] = np.zeros(shape, dtype=bool)
    for (ix, iy), values in cells.items():
        at = (ix - lo[0], iy - lo[1])
        dense["visited"][at] = True
        for name, value in values.items():
            dense[name][at] = value
    return lo, dense


def test_archive_holds_the_last_value_of_every_cell_over_a_random_walk():
    rng = np.random.default_rng(7)
    archive = WorldArchive(CELL)
    stores = []
    corner = np.array([0, 0])
    for _ in range(60):
        corner = corner + rng.integers(-4, 5, 2)  # the grid scrolls by whole cells
        shape = (12, 9)
        types, heights, in_view = _grid_values(rng, shape)
        store(archive, centers(*shape, *(corner * CELL)), types, heights, in_view=in_view)
        stores.append((tuple(corner), types, heights, in_view))
    lo, expected = _model(stores)
    for name, values in expected.items():
        actual = getattr(archive, name)
        assert actual.flags.c_contiguous and not actual.flags.writeable
        np.testing.assert_array_equal(actual, values, err_msg=name)
    np.testing.assert_allclose(archive.cell_centers_xy()[0, 0], (np.array(lo) + 0.5) * CELL)
    assert archive.cell_centers_xy().shape == (*expected["visited"].shape, 2)


def test_a_long_walk_grows_the_storage_a_logarithmic_number_of_times():
    """1000 one-cell steps east, then 1000 north: each growth at least doubles a side."""
    archive = WorldArchive(CELL)
    types, heights, _ = _grid_values(np.random.default_rng(0), (20, 20))
    sizes = []
    steps = [(i, 0) for i in range(1000)] + [(999, j) for j in range(1, 1000)]
    for ix, iy in steps:
        store(archive, centers(20, 20, ix * CELL, iy * CELL), types, heights)
        sizes.append(archive.storage_cells)
    growths = sum(1 for a, b in itertools.pairwise(sizes) if b != a)
    assert growths <= 2 * 8, growths  # log2(1019 / 20) ≈ 6 doublings per direction
    box = archive.visited.size
    assert box == 1019 * 1019
    assert archive.storage_cells <= 4 * box


def test_archive_memory_is_bounded_by_its_box_not_by_its_history():
    archive = WorldArchive(CELL)
    types, heights, _ = _grid_values(np.random.default_rng(1), (100, 100))
    tracemalloc.start()
    try:
        for step in range(200):  # 8 m east in 4 cm steps: a 299 x 100 cell box
            store(archive, centers(100, 100, step * CELL, 0.0), types, heights)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    box = archive.visited.size
    assert box == 299 * 100
    # Storage (at most 2x the box along the side that grew), one growth's copy, the grids.
    assert peak <= 2 * 2 * box * BYTES_PER_CELL + 10 * 100 * 100 * 8, peak


@pytest.mark.parametrize("jump_m", [100.0, 300.0, 3000.0])
def test_a_jump_beyond_the_maximum_extent_is_refused_before_allocating(jump_m):
    """100 m and more: the box would pass MAX_ARCHIVE_CELLS (2048² cells of 4 cm)."""
    archive = WorldArchive(CELL)
    types, heights, _ = _grid_values(np.random.default_rng(2), (100, 100))
    store(archive, centers(100, 100), types, heights)
    tracemalloc.start()
    try:
        with pytest.raises(ArchiveExtentError, match=r"span \d+ × \d+ cells .*MAX_ARCHIVE"):
            store(archive, centers(100, 100, jump_m, jump_m), types, heights)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak <= 1 << 20, peak  # nothing allocated for the jump
    assert archive.visited.shape == (100, 100)  # the archive is unchanged
