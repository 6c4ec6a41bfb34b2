"""A run's archive stored once per place of the grid is the archive of every frame, bit for bit."""

from types import SimpleNamespace

import numpy as np

from fogsim.eval.archive import WorldArchive
from fogsim.run.runner import _GridArchiver
from mapper import MapperParams
from mapper.grid import GridGeometry

LAYERS = (
    "fog_types",
    "fog_heights_m",
    "floor_m",
    "obstacle_m",
    "ceiling_m",
    "baseline_heights_m",
    "visited",
    "in_view",
)


def _frames(rng, geometry, count):
    """``count`` frames of random maps; the grid stays 1-5 frames, then moves by whole cells."""
    shape = (geometry.nx, geometry.ny)
    stay = 0
    for _ in range(count):
        if stay == 0:
            geometry = geometry.shifted(*(int(v) for v in rng.integers(-3, 4, 2)))
            stay = int(rng.integers(1, 6))
        stay -= 1
        heights = [
            np.where(rng.random(shape) < 0.3, np.nan, rng.normal(size=shape)) for _ in "abcde"
        ]
        yield (
            geometry,
            rng.integers(0, 3, shape).astype(np.int8),
            heights,
            rng.random(shape) < 0.2,
        )


def test_storing_once_per_place_leaves_the_archive_of_every_frame():
    rng = np.random.default_rng(3)
    start = GridGeometry.from_params(MapperParams(nx=12, ny=9))
    every, once = WorldArchive(start.cell_m), WorldArchive(start.cell_m)
    archiver = _GridArchiver(once)
    stores, places, previous = [], 0, None
    once_store = once.store_grid
    once.store_grid = lambda *args, **kwargs: stores.append(1) or once_store(*args, **kwargs)
    for geometry, types, (fog, base, floor, obstacle, ceiling), in_view in _frames(rng, start, 80):
        places += geometry != previous
        previous = geometry
        layers = {"floor_m": floor, "obstacle_m": obstacle, "ceiling_m": ceiling}
        every.store_grid(geometry.cell_center(0, 0), types, fog, base, **layers, in_view=in_view)
        mapper = SimpleNamespace(geometry=geometry, **{k[:-2]: v.copy for k, v in layers.items()})
        archiver.add(SimpleNamespace(mapper=mapper), (types, fog, base), in_view)
    archiver.flush()
    assert len(stores) == places < 80
    for name in LAYERS:
        np.testing.assert_array_equal(getattr(once, name), getattr(every, name), err_msg=name)
    np.testing.assert_array_equal(once.cell_centers_xy(), every.cell_centers_xy())
    assert once.storage_cells == every.storage_cells
