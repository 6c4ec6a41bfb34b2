"""The FOG and obstacle heights recomputed when read are those recomputed after every update.

`FloorObstacleMapper.update` marks the area it changed and `fog()`, `obstacle()` and
`recenter()` recompute the derived maps over every area marked since (`_refresh_fog`). A mapper
whose FOG is read after every update (each read recomputes one frame's area, as the update did
before) and one read only now and then must hold the same bits, through a walk over a staircase
and boxes with the grid scrolling, with every FOG rule of the defaults and with the rules that
are off by default (margin, raised rims, island rule) on.
"""

from dataclasses import replace

import numpy as np
import pytest

from mapper import CellType, FloorObstacleMapper, MapperParams, PinholeIntrinsics
from mapper.synthetic import Box, camera_rays_world, cast_frame

INTR = PinholeIntrinsics.from_fov(88, 72, 47.0, 39.0)
RAYS = camera_rays_world(INTR, yaw_deg=0.0, pitch_down_deg=30.0)
#: A staircase (31, 61, 92 mm) to a 122 mm platform, a sill and two boxes beside the route.
BOXES = [
    Box((0.9, 0.0), (0.08, 0.8, 0.038)),
    *(Box((1.5 + 0.2 * i, 0.0), (0.2, 0.8, h)) for i, h in enumerate((0.031, 0.061, 0.092))),
    Box((2.4, 0.0), (0.6, 0.8, 0.122)),
    Box((1.3, 0.7), (0.3, 0.3, 0.22)),
    Box((1.8, -0.7), (0.4, 0.3, 0.06)),
]
DEFAULTS = MapperParams()
OFF_BY_DEFAULT = replace(
    DEFAULTS, obstacle_margin_cells=1, raised_rim_obstacle=True, min_floor_neighbours=3
)


def _walk(params: MapperParams, read_every: int, frames: int = 60):
    """Walk 1.5 m along x (the grid scrolls), mapping noisy frames; read the FOG every
    ``read_every`` updates (0: never). Returns the mapper and the FOG labels read on the way."""
    rng = np.random.default_rng(7)
    mapper = FloorObstacleMapper(params)
    reads = []
    for k in range(frames):
        x = 0.025 * k
        camera = np.array([x, 0.02 * np.sin(k / 5.0), 0.55])
        mapper.recenter(x, 0.0)
        points, heights = cast_frame(camera, RAYS, BOXES, noise_z_m=0.006, rng=rng)
        mapper.update(points, heights, camera)
        if read_every and k % read_every == read_every - 1:
            reads.append(mapper.fog()[0])
    return mapper, reads


@pytest.mark.parametrize("params", [DEFAULTS, OFF_BY_DEFAULT], ids=["defaults", "rules_off"])
def test_fog_read_rarely_is_the_fog_read_after_every_update(params: MapperParams) -> None:
    eager, every = _walk(params, read_every=1)
    lazy, rarely = _walk(params, read_every=7)
    start = FloorObstacleMapper(params).geometry
    assert eager.geometry == lazy.geometry
    assert eager.geometry.origin_ix > start.origin_ix  # the grid scrolled
    assert np.array_equal(eager.occupancy_levels(), lazy.occupancy_levels())
    assert np.array_equal(eager.floor(), lazy.floor(), equal_nan=True)
    types, heights = eager.fog()
    lazy_types, lazy_heights = lazy.fog()
    assert np.array_equal(types, lazy_types)
    assert np.array_equal(heights, lazy_heights, equal_nan=True)
    assert np.array_equal(eager.obstacle(), lazy.obstacle(), equal_nan=True)
    # The reads on the way agree too (after frames 7, 14, ...), and the map is no trivial one.
    assert all(np.array_equal(every[k * 7 + 6], r) for k, r in enumerate(rarely))
    assert (types == CellType.FLOOR).sum() > 1000 and (types == CellType.OBSTACLE).sum() > 20


def test_fog_never_read_until_the_end_is_the_same() -> None:
    eager, _ = _walk(DEFAULTS, read_every=1, frames=40)
    lazy, _ = _walk(DEFAULTS, read_every=0, frames=40)
    assert np.array_equal(eager.fog()[0], lazy.fog()[0])
    assert np.array_equal(eager.fog()[1], lazy.fog()[1], equal_nan=True)


def test_obstacle_read_first_brings_the_fog_up_to_date() -> None:
    # A box in view: its obstacle heights are there when read, before any fog() call, and the
    # FOG read after them labels its flat top a floor at its height (eq. 11: h_o <= h_f + δ).
    mapper = FloorObstacleMapper(DEFAULTS)
    rng = np.random.default_rng(3)
    camera = np.array([0.0, 0.0, 0.55])
    box = Box((1.2, 0.0), (0.3, 0.3, 0.20))
    for _ in range(8):
        mapper.update(*cast_frame(camera, RAYS, [box], noise_z_m=0.004, rng=rng), camera)
    assert mapper._stale_area is not None  # nothing read yet
    obstacle = mapper.obstacle()
    assert mapper._stale_area is None
    ix, iy = mapper.geometry.cell_of(np.array([[1.2, 0.0]]))[0][0]
    # eq. 10: the top face of the layer holding the box top (0.20 m: layer 6, top 0.22 m)
    assert obstacle[ix, iy] == pytest.approx(DEFAULTS.z_min_m + 7 * DEFAULTS.layer_m)
    types, heights = mapper.fog()
    assert types[ix, iy] == CellType.FLOOR
    assert heights[ix, iy] == pytest.approx(0.20, abs=0.004)
