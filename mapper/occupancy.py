"""8-bit Bayesian 3D occupancy grid: lookup tables (eqs. 6, 12, 13) and exact ray insertion.

Storage: ``uint8`` level ``L`` per cell meaning probability ``L / 256`` (128 ↔ 0.5 exactly).
Levels are clamped to ``[params.level_min, params.level_max]`` (i.e. to ``[p_min, p_max]``).

Update rule — once per frame, occupied wins (DESIGN item 1): within one ``insert_frame`` call a
cell receives at most one update. Cells holding a point's end get the hit update; cells only
crossed by rays get one miss update however many rays cross them; a cell both hit and crossed
gets the hit. This is OctoMap's point-cloud insertion rule. A per-ray rule would let the dozens
of grazing rays that cross a floor cell near its own points erase it every frame, and would make
how fast a removed object is forgotten depend on how many rays happen to cross it.

Ray traversal: Amanatides & Woo (1987), in grid units, the segment from the sensor to the point
clipped to the grid box first, so a sensor above or beside the grid still clears the cells its
rays cross. With ``free_margin_m > 0`` a ray clears cells only up to the cell holding the point
``free_margin_m`` before its end (see `MapperParams.free_margin_m` for why). The traversal takes
exactly ``|Δix| + |Δiy| + |Δiz|`` steps from the entry cell
to the end (or stop) cell, so it always ends there.

Ends with no hit (OctoMap's ``insertPointCloud`` with ``maxrange``): a point outside the grid
volume (x, y or z), or farther than ``max_range_m`` from the sensor, marks no cell as hit, but
its ray still clears every cell it crosses inside the grid — the segment clipped on both sides
(entry at the sensor or a face, exit at a face), truncated at ``max_range_m`` from the sensor,
and stopped ``free_margin_m`` before the true end if that lies inside; the last cell is cleared
too. Without this the grid's border columns and far cells collect hits from noisy points but
are never cleared by the rays passing through them to farther points, and become false
obstacles (stage scenario: 94.5 → 96.8 % cells right). With ``clear_outside=False`` (the
default for now, see `MapperParams.clear_outside`) such points are ignored entirely.

Discretized insertion (``discretize``, `MapperParams.discretize_rays`; OctoMap's
``insertPointCloud(..., discretize=true)``): the points are first reduced to the lattice cells
holding them (inside the grid or not; a hash set per frame), and one ray is cast per cell, from
the sensor to the cell's centre; every point of the cell gets the centre's status (hit, outside,
beyond range). The hits are the same cells; the cleared cells differ only near the rays' ends.
On the stage's 88 × 72 frames 5 950 points become 2 520 rays (the 3 970 points inside the grid
1 060), at 176 × 144 24 000 points 3 900 rays: the insert takes 0.36 instead of 0.57 ms (CPU,
median over seed 1's 832 frames), 0.75 instead of 1.98 ms at 176 × 144. After the 832 frames
1.1 % of the cells hold another level, 26 of 9 884 occupied cells differ
(``tests/test_insert_discretize.py``; the OctoMap comparison in
``tests/test_occupancy_octomap.py`` agrees with OctoMap's ``discretize`` exactly, as the exact
mode does with its exact insertion). The kernels take the hash set as their ``cells`` argument
(`cell_set`), None when not discretizing: numba then prunes that path before typing the kernel,
so the default run does not compile it (`insert_frame_columns` 6.7 → 5.2 s of compile CPU,
Intel Xeon, load 7-8, `bench/bench_cold.py kernels --group mapper`).

Repeated end cells (``repeat_ray_columns``, `MapperParams.repeat_ray_columns`, off by default;
`insert_frame_columns` only): a point whose end cell an earlier point of the frame already hit
walks only its last columns (`_repeat_start`): rays to one cell differ by less than a cell far
from it, and most of the bits a ray adds lie near its end. Not exact: the cells far from the
ends are then cleared only by the first ray to each end cell (measured in the parameter's
docstring). On the stage's frames 4 000 of the 5 950 points lie in the grid, in about 1 080
end cells, and their rays make 88 k of the 141 k column steps; the 1 930 rays of points
outside the grid make 53 k (27 a ray; they lie in 1 420 lattice cells, so discretizing them
alone would save little).

Two kernels keep the once-per-frame marks: `insert_frame_columns` (the mapper's default when
``nz <= 64``) keeps one bit per layer in one word per column and steps the traversal only at
x/y cell boundaries, marking the run of layers a ray crosses inside a column with one OR (1.6 to
1.7× faster than the other on the stage's frames, host and ``generic`` codegen, Intel Xeon,
`bench/bench_mapper.py`);
`insert_frame` keeps one bit per cell and steps through every cell (any ``nz``). Both mark the
same cells (tests compare them with each other and with a brute-force slab test).

Code generation: both run as fast compiled for the host CPU as for numba's ``generic`` target.
Their walks never select an infinite crossing parameter for an axis without crossings left (a
select on the loop's dependency chain that LLVM compiled 2× slower for an AVX-512 host than for
``generic``): they loop while every axis has crossings left, then over the axes left. No FMA
contraction either: it is used only where the CPU has FMA, so the rounding of ``sz + t·dz`` — and
in rare ties the marked cells — would depend on the CPU.
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

from mapper.params import LEVELS, MapperParams

#: ``point_cell`` codes of points that get no hit (see `insert_frame`).
OUTSIDE = -1
NONFINITE = -2
BEYOND_RANGE = -3

#: numba options of the small per-ray helpers that take only scalars (classification, slab
#: tests, first crossings, the clamped cell — inlined, it was compiled at 15 call sites):
#: compiled once each as functions of their own, not inlined into every kernel's numba IR
#: (``inline="always"``), which compiled them again inside each caller and made
#: `insert_frame_columns` the costliest compile of a cold start. LLVM still inlines
#: them into the kernels (checked in the kernel's assembly: no call left; they take no arrays,
#: so no reference counting at the call). `_clip_ray` and `_clip_ray_through` stay inlined in
#: numba IR: compiled on their own LLVM kept them as calls (15 values returned through memory
#: once a ray: the stage's insert 2.6 % slower). The kernels' flags (`fogsim.run.warmup` and
#: its test: one flag set for every kernel, so that numba's overloads are compiled once).
_SCALAR_HELPER = {"cache": True, "no_cfunc_wrapper": True, "nogil": True, "error_model": "numpy"}


def mark_buffer_size(cell_count: int) -> int:
    """Bytes of the ``mark`` scratch of `insert_frame`: a hit and a miss bitset."""
    return 2 * ((cell_count + 7) // 8)


def bayes_update(p_cell: NDArray[np.float64] | float, likelihood_occupied: float):
    """Eq. 6 with eq. 13: posterior of a cell with prior ``p_cell`` for ``P(p|c)=likelihood``."""
    num = likelihood_occupied * p_cell
    return num / (num + (1.0 - likelihood_occupied) * (1.0 - p_cell))


def lookup_tables(params: MapperParams) -> tuple[NDArray[np.uint8], NDArray[np.uint8]]:
    """The (hit, miss) tables: ``new_level = table[old_level]`` for all 256 levels.

    Hit uses ``P(p|c) = p_sense`` (eq. 12, the point's cell), miss ``1 - p_sense`` (cells
    before it). The posterior is clamped to ``[p_min, p_max]`` and rounded to the nearest level;
    if rounding would leave a cell below ``level_max`` unchanged by a hit (or above
    ``level_min`` by a miss) it moves by one level, so the clamps are always reached.
    """
    levels = np.arange(LEVELS, dtype=np.float64)
    prior = levels / LEVELS
    lo, hi = params.level_min, params.level_max
    tables = []
    for likelihood, direction in ((params.p_sense, 1), (1.0 - params.p_sense, -1)):
        post = np.clip(bayes_update(prior, likelihood), params.p_min, params.p_max)
        new = np.clip(np.rint(post * LEVELS), lo, hi).astype(np.int64)
        old = levels.astype(np.int64)
        if direction > 0:
            stalled = (new <= old) & (old < hi)
            new[stalled] = np.minimum(old[stalled] + 1, hi)
        else:
            stalled = (new >= old) & (old > lo)
            new[stalled] = np.maximum(old[stalled] - 1, lo)
        tables.append(np.clip(new, lo, hi).astype(np.uint8))
    return tables[0], tables[1]


@numba.njit(cache=True, inline="always")
def floor_int(v: float) -> int:
    """``int(np.floor(v))`` for finite ``v``: truncation, one lower for negative non-integers.

    Written out because numba's ``generic`` target (x86-64 without SSE4.1) has no rounding
    instruction and would call libm's ``floor`` for every coordinate.
    """
    i = int(v)
    return i - 1 if v < i else i


@numba.njit(**_SCALAR_HELPER)
def _clamped_cell(v: float, n: int) -> int:
    """``min(max(floor(v), 0), n - 1)`` for finite ``v``: the cell of a grid coordinate, clamped.

    Clamped as a float, then truncated (the same cell: truncation and ``floor`` differ only
    below 0, clamped to 0 either way) — ``minsd``/``maxsd`` where integer compares of a floor
    compile to branches.
    """
    return int(min(max(v, 0.0), n - 1.0))


@numba.njit(**_SCALAR_HELPER)
def grid_point(x, y, z, origin_x, origin_y, z_min, cell, layer, nx, ny, nz):
    """A world point [m] in grid units and its cell (numba, for kernels on the same grid).

    The cell convention of `mapper.grid`: ``gx = (x - origin_x) / cell``, ``ix = floor(gx)``,
    likewise y; ``gz = (z - z_min) / layer``. The occupancy kernels and `mapper.averaging` use
    this one function so that every map puts a point into the same cell.

    Args:
        x: World x of the point [m].
        y: World y of the point [m].
        z: World z of the point [m].
        origin_x: World x of the grid's corner [m].
        origin_y: World y of the grid's corner [m].
        z_min: World z of the grid's lowest face [m].
        cell: Cell side [m].
        layer: Layer height [m].
        nx: Cells along x.
        ny: Cells along y.
        nz: Layers.

    Returns:
        (status, gx, gy, gz, ix, iy, iz): status 0 if the point lies in the grid, `OUTSIDE` if
        it is outside, `NONFINITE` if a coordinate is not finite (the other values are then
        meaningless); ``gx, gy, gz`` in cells and layers from the grid's corner.
    """
    if not (np.isfinite(x) and np.isfinite(y) and np.isfinite(z)):
        return NONFINITE, 0.0, 0.0, 0.0, 0, 0, 0
    gx = (x - origin_x) / cell
    gy = (y - origin_y) / cell
    gz = (z - z_min) / layer
    ix = floor_int(gx)
    iy = floor_int(gy)
    iz = floor_int(gz)
    inside = 0 <= ix < nx and 0 <= iy < ny and 0 <= iz < nz
    return (0 if inside else OUTSIDE), gx, gy, gz, ix, iy, iz


@numba.njit(**_SCALAR_HELPER)
def _first_crossing(remaining: int, d: float, inv_d: float, s: float, c: int):
    """Ray parameter of the first cell-boundary crossing along one axis and its increment.

    ``s`` is the start coordinate in cell units, ``c`` its cell, ``d`` the segment's extent
    along the axis and ``inv_d = 1 / d`` (multiplications instead of divisions: a division
    costs several multiplications' time); axes without crossings (``remaining == 0``) never
    step (inf).
    """
    if remaining == 0 or d == 0.0:
        return np.inf, np.inf
    if d > 0.0:
        return (c + 1.0 - s) * inv_d, inv_d
    return (c - s) * inv_d, -inv_d


@numba.njit(**_SCALAR_HELPER)
def _slab_enter(t0: float, s: float, d: float, inv_d: float, upper: float) -> float:
    """Raise ``t0`` to where the segment ``s + t·d`` enters the slab ``[0, upper]`` (2: never)."""
    if d != 0.0:
        ta = (0.0 - s) * inv_d
        tb = (upper - s) * inv_d
        return max(t0, min(ta, tb))
    if s < 0.0 or s > upper:
        return 2.0  # parallel to this slab and outside it: cannot happen for an inside end
    return t0


@numba.njit(cache=True, inline="always")
def _clip_ray(ox, oy, oz, gx, gy, gz, ix, iy, iz, nx, ny, nz, free_margin, length_m):
    """The part of the ray from the sensor ``o`` to the end ``g`` (grid units) to walk.

    The segment is clipped to the grid box; with ``free_margin > 0`` it stops ``free_margin``
    before the end (``length_m`` is the ray's length [m]) and the stop cell is cleared too.

    Returns:
        (walk, sx, sy, sz, dx, dy, dz, inv_d, cx, cy, cz, ex, ey, ez, stop_cleared):
        ``walk`` False if nothing is cleared; else the entry point ``s`` and the cell ``c``
        holding it, the segment's direction ``d`` (the full segment, grid units) and
        ``inv_d = (1/dx, 1/dy, 1/dz)`` (0 for a zero component), and the last cell ``e``.
    """
    dx = gx - ox
    dy = gy - oy
    dz = gz - oz
    inv_dx = 1.0 / dx if dx != 0.0 else 0.0
    inv_dy = 1.0 / dy if dy != 0.0 else 0.0
    inv_dz = 1.0 / dz if dz != 0.0 else 0.0
    t0 = _slab_enter(0.0, ox, dx, inv_dx, float(nx))
    t0 = _slab_enter(t0, oy, dy, inv_dy, float(ny))
    t0 = _slab_enter(t0, oz, dz, inv_dz, float(nz))
    walk = t0 < 1.0  # else the sensor is in the end cell's plane outside the box
    stop_cleared = free_margin > 0.0
    ex = ix
    ey = iy
    ez = iz
    if walk and stop_cleared:
        t_stop = 1.0 - free_margin / length_m
        walk = t_stop > t0
        ex = _clamped_cell(ox + t_stop * dx, nx)
        ey = _clamped_cell(oy + t_stop * dy, ny)
        ez = _clamped_cell(oz + t_stop * dz, nz)
    sx = ox + t0 * dx
    sy = oy + t0 * dy
    sz = oz + t0 * dz
    cx = _clamped_cell(sx, nx)
    cy = _clamped_cell(sy, ny)
    cz = _clamped_cell(sz, nz)
    inv_d = (inv_dx, inv_dy, inv_dz)
    return walk, sx, sy, sz, dx, dy, dz, inv_d, cx, cy, cz, ex, ey, ez, stop_cleared


@numba.njit(**_SCALAR_HELPER)
def _slab_clip(t0: float, t1: float, s: float, d: float, inv_d: float, upper: float):
    """Narrow ``[t0, t1]`` to where the segment ``s + t·d`` lies in the slab ``[0, upper]``."""
    if d != 0.0:
        ta = (0.0 - s) * inv_d
        tb = (upper - s) * inv_d
        return max(t0, min(ta, tb)), min(t1, max(ta, tb))
    if s < 0.0 or s > upper:
        return 2.0, -1.0  # parallel to this slab and outside it: the segment misses the box
    return t0, t1


@numba.njit(cache=True, inline="always")
def _clip_ray_through(ox, oy, oz, gx, gy, gz, nx, ny, nz, t_limit):
    """The part to clear of a ray whose end gets no hit (outside the grid or beyond range).

    The segment from the sensor ``o`` to the end ``g`` (grid units) is clipped to the grid box
    on both sides (entry at the sensor or a face, exit at a face) and to ``t <= t_limit`` (the
    free-margin stop or the maximum range as a fraction of the segment); every cell of what
    is left is cleared, the last one included.

    Returns:
        As `_clip_ray`, ``stop_cleared`` always True.
    """
    dx = gx - ox
    dy = gy - oy
    dz = gz - oz
    inv_dx = 1.0 / dx if dx != 0.0 else 0.0
    inv_dy = 1.0 / dy if dy != 0.0 else 0.0
    inv_dz = 1.0 / dz if dz != 0.0 else 0.0
    t0, t1 = _slab_clip(0.0, t_limit, ox, dx, inv_dx, float(nx))
    t0, t1 = _slab_clip(t0, t1, oy, dy, inv_dy, float(ny))
    t0, t1 = _slab_clip(t0, t1, oz, dz, inv_dz, float(nz))
    walk = t1 > t0
    if not walk:  # keep the cell arithmetic below finite and in range
        t0 = 0.0
        t1 = 0.0
    sx = ox + t0 * dx
    sy = oy + t0 * dy
    sz = oz + t0 * dz
    cx = _clamped_cell(sx, nx)
    cy = _clamped_cell(sy, ny)
    cz = _clamped_cell(sz, nz)
    ex = _clamped_cell(ox + t1 * dx, nx)
    ey = _clamped_cell(oy + t1 * dy, ny)
    ez = _clamped_cell(oz + t1 * dz, nz)
    inv_d = (inv_dx, inv_dy, inv_dz)
    return walk, sx, sy, sz, dx, dy, dz, inv_d, cx, cy, cz, ex, ey, ez, True


@numba.njit(**_SCALAR_HELPER)
def _no_hit_limit(status: int, length: float, free_margin: float, max_range: float) -> float:
    """``t_limit`` of `_clip_ray_through`: the margin stop and, beyond range, the range."""
    t_limit = max_range / length if status == BEYOND_RANGE else 1.0
    if free_margin > 0.0:
        t_limit = min(t_limit, 1.0 - free_margin / length)
    return t_limit


@numba.njit(**_SCALAR_HELPER)
def _classify(x, y, z, sensor_x, sensor_y, sensor_z, geometry, shape, need_length, max_range):
    """`grid_point` of a world point plus its range from the sensor [m].

    ``geometry`` is (origin_x, origin_y, z_min, cell, layer), ``shape`` (nx, ny, nz). The
    range is computed only when ``need_length`` (else 0); a finite point farther than
    ``max_range`` [m] gets status ``BEYOND_RANGE`` whether its end lies in the grid or not.

    Returns:
        (status, gx, gy, gz, ix, iy, iz, length): status 0 (in the grid), ``OUTSIDE``,
        ``NONFINITE`` or ``BEYOND_RANGE``.
    """
    origin_x, origin_y, z_min, cell, layer = geometry
    nx, ny, nz = shape
    status, gx, gy, gz, ix, iy, iz = grid_point(
        x, y, z, origin_x, origin_y, z_min, cell, layer, nx, ny, nz
    )
    length = 0.0
    if status != NONFINITE and need_length:
        length = np.sqrt((x - sensor_x) ** 2 + (y - sensor_y) ** 2 + (z - sensor_z) ** 2)
        if length > max_range:
            status = BEYOND_RANGE
    return status, gx, gy, gz, ix, iy, iz, length


#: `_cell_set` code of an empty slot (a status is never positive).
_EMPTY_SLOT = 1


def cell_set(n_points: int) -> tuple[NDArray[np.int64], NDArray[np.int8]]:
    """Scratch of the discretized insertion (`_discretized`) of ``n_points`` points.

    The kernels' ``cells`` argument: an open-addressing set of lattice cells with their
    status, made afresh for each frame. A kernel passed None instead is compiled without the
    discretized path (numba prunes the branches on ``cells is None`` before it types the
    kernel): a run that does not discretize does not compile that path.

    Returns:
        (keys (capacity, 3) int64 uninitialised, codes (capacity,) int8 all `_EMPTY_SLOT`: one
        byte a slot, so that filling them costs little); the capacity is the smallest power of
        two at least twice the points (probes stay short), and at least 1.
    """
    capacity = 1
    while capacity < 2 * n_points:
        capacity *= 2
    return np.empty((capacity, 3), dtype=np.int64), np.full(capacity, _EMPTY_SLOT, np.int8)


@numba.njit(cache=True, inline="always")
def _discretized(cells, end, sensor_grid, scale, shape, need_length, max_range):
    """OctoMap's ``discretize``: one ray per lattice cell holding points, to the cell's centre.

    ``end`` is `_classify`'s result for a point. The first point in a lattice cell (inside the
    grid or not) gets the ray of the cell's centre: its grid coordinates ``i + 0.5``, its range
    from the sensor and its status (in the grid, outside, beyond ``max_range``) are the
    centre's; a later point in the same cell gets the same status and no ray.

    Args:
        cells: `cell_set` scratch, updated.
        end: (status, gx, gy, gz, ix, iy, iz, length) of the point.
        sensor_grid: (ox, oy, oz) the sensor in grid units.
        scale: (cell, layer) [m].
        shape: (nx, ny, nz).
        need_length: Compute the range (else 0).
        max_range: [m], as in `insert_frame`.

    Returns:
        (cast, status, gx, gy, gz, ix, iy, iz, length): ``cast`` False for a point whose
        cell already has its ray (and for a non-finite point).
    """
    status, gx, gy, gz, ix, iy, iz, length = end
    if status == NONFINITE:
        return False, status, gx, gy, gz, ix, iy, iz, length
    keys, codes = cells
    mask = codes.shape[0] - 1
    slot = ((ix * 73856093) ^ (iy * 19349663) ^ (iz * 83492791)) & mask
    while codes[slot] != _EMPTY_SLOT:
        if keys[slot, 0] == ix and keys[slot, 1] == iy and keys[slot, 2] == iz:
            return False, np.int64(codes[slot]), gx, gy, gz, ix, iy, iz, length
        slot = (slot + 1) & mask
    keys[slot, 0] = ix
    keys[slot, 1] = iy
    keys[slot, 2] = iz
    ox, oy, oz = sensor_grid
    cell, layer = scale
    nx, ny, nz = shape
    gx = ix + 0.5
    gy = iy + 0.5
    gz = iz + 0.5
    status = 0 if (0 <= ix < nx and 0 <= iy < ny and 0 <= iz < nz) else OUTSIDE
    length = 0.0
    if need_length:
        length = np.sqrt(
            ((gx - ox) * cell) ** 2 + ((gy - oy) * cell) ** 2 + ((gz - oz) * layer) ** 2
        )
        if length > max_range:
            status = BEYOND_RANGE
    codes[slot] = status
    return True, status, gx, gy, gz, ix, iy, iz, length


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def insert_frame(
    points: NDArray[np.float64],
    sensor_origin: NDArray[np.float64],
    origin_x: float,
    origin_y: float,
    z_min: float,
    cell: float,
    layer: float,
    og: NDArray[np.uint8],
    mark: NDArray[np.uint8],
    touched: NDArray[np.int64],
    hit_table: NDArray[np.uint8],
    miss_table: NDArray[np.uint8],
    point_cell: NDArray[np.int64],
    free_margin: float = 0.0,
    max_range: float = np.inf,
    clear_outside: bool = False,
    cells: tuple[NDArray[np.int64], NDArray[np.int8]] | None = None,
):
    """Insert one frame of points into the 3D grid ``og`` (nx, ny, nz) in place.

    A point inside the grid and within ``max_range`` is a hit; its ray clears the cells
    before it. A point outside the grid (x, y or z) or beyond ``max_range`` is no hit, but
    with ``clear_outside`` its ray still clears every cell it crosses inside the grid (up to
    the grid's face, or up to ``max_range`` from the sensor, and at most up to ``free_margin``
    before the true end) — OctoMap's ``insertPointCloud`` with ``maxrange``.

    Args:
        points: (N, 3) world points [m].
        sensor_origin: (3,) world sensor position [m].
        origin_x: World x of the grid's corner [m].
        origin_y: World y of the grid's corner [m].
        z_min: World z of the grid's lowest face [m].
        cell: Cell side [m].
        layer: Layer height [m].
        og: (nx, ny, nz) uint8 levels, updated in place.
        mark: ``mark_buffer_size(nx*ny*nz)`` uint8 scratch, all zero on entry and on return:
            two bitsets (hit, miss) of one bit per cell — 40 kB for the default grid, so the
            per-visit "already updated this frame?" test stays in the L1 cache.
        touched: (nx*ny*nz,) int64 scratch.
        hit_table: Hit table from ``lookup_tables``.
        miss_table: Miss table from ``lookup_tables``.
        point_cell: (N,) out: the point's (ix, iy) column index ``ix*ny + iy``, or for a
            point that is no hit ``OUTSIDE`` (-1), ``NONFINITE`` (-2), ``BEYOND_RANGE`` (-3).
        free_margin: Rays stop clearing this far [m] before their end point (0: every cell
            before the end cell is cleared, the paper's model).
        max_range: Points farther than this from the sensor [m] are no hit (inf: none).
        clear_outside: Rays of points outside the grid or beyond ``max_range`` clear the
            cells they cross (False: such points are ignored entirely).
        cells: `cell_set` scratch for ``len(points)`` points: one ray per lattice cell
            holding points, to the cell's centre, whose status (hit, outside, beyond range) all
            its points get (`_discretized`; OctoMap's ``discretize``). None: one ray per point,
            to the point, and the discretized path is not compiled (`cell_set`). Always pass
            it (None included): numba compiles an omitted argument as another signature.

    Returns:
        (used, dropped_nonfinite, dropped_outside, beyond_range, cells_updated, ix0, ix1, iy0,
        iy1) with the half-open affected area (ix0 == nx when nothing changed);
        ``dropped_outside`` counts the finite points within range whose end is outside the
        grid, ``beyond_range`` the finite points beyond ``max_range``.
    """
    nx, ny, nz = og.shape
    flat = og.reshape(-1)
    miss_base = mark.shape[0] // 2
    n_points = points.shape[0]
    stride_x = ny * nz
    stride_y = nz
    n_touched = 0
    dropped_nonfinite = 0
    dropped_outside = 0
    beyond_range = 0
    used = 0
    geometry = (origin_x, origin_y, z_min, cell, layer)
    shape = (nx, ny, nz)
    need_length = free_margin > 0.0 or max_range < np.inf
    ox = (sensor_origin[0] - origin_x) / cell
    oy = (sensor_origin[1] - origin_y) / cell
    oz = (sensor_origin[2] - z_min) / layer
    # Affected area: each ray's cells lie between its first and last cell in x and y (the
    # traversal is monotonic), so the box comes from the ends, without decoding cell indices.
    ix0 = nx
    ix1 = -1
    iy0 = ny
    iy1 = -1
    end_g = np.empty((n_points, 3))
    end_i = np.empty((n_points, 3), dtype=np.int64)
    end_length = np.empty(n_points)
    cast_ray = np.empty(n_points, dtype=np.bool_)
    # Pass 1: end cells get the hit mark first, so they win over any miss this frame.
    for i in range(n_points):
        status, gx, gy, gz, ix, iy, iz, length = _classify(
            points[i, 0],
            points[i, 1],
            points[i, 2],
            sensor_origin[0],
            sensor_origin[1],
            sensor_origin[2],
            geometry,
            shape,
            need_length and cells is None,
            max_range,
        )
        cast = True
        if cells is not None:  # pruned by numba when None: compiled only for discretizing
            end = (status, gx, gy, gz, ix, iy, iz, length)
            cast, status, gx, gy, gz, ix, iy, iz, length = _discretized(
                cells, end, (ox, oy, oz), (cell, layer), shape, need_length, max_range
            )
        cast_ray[i] = cast
        end_g[i, 0] = gx
        end_g[i, 1] = gy
        end_g[i, 2] = gz
        end_length[i] = length
        if status < 0:
            dropped_nonfinite += status == NONFINITE
            dropped_outside += status == OUTSIDE
            beyond_range += status == BEYOND_RANGE
            point_cell[i] = status
            continue
        point_cell[i] = ix * ny + iy
        end_i[i, 0] = ix
        end_i[i, 1] = iy
        end_i[i, 2] = iz
        used += 1
        ix0 = min(ix0, ix)
        ix1 = max(ix1, ix)
        iy0 = min(iy0, iy)
        iy1 = max(iy1, iy)
        idx = ix * stride_x + iy * stride_y + iz
        byte = idx >> 3
        bit = np.uint8(1 << (idx & 7))
        if not mark[byte] & bit:
            mark[byte] |= bit
            touched[n_touched] = idx
            n_touched += 1
    # Pass 2: rays, clipped to the grid box, from the entry cell to the end (or stop) cell;
    # rays of no-hit ends from the entry cell to the exit (or stop, or range) cell.
    for i in range(n_points):
        status = point_cell[i]
        if not cast_ray[i]:
            continue
        if status >= 0:
            clip = _clip_ray(
                ox,
                oy,
                oz,
                end_g[i, 0],
                end_g[i, 1],
                end_g[i, 2],
                end_i[i, 0],
                end_i[i, 1],
                end_i[i, 2],
                nx,
                ny,
                nz,
                free_margin,
                end_length[i],
            )
        elif clear_outside and status != NONFINITE:
            t_limit = _no_hit_limit(status, end_length[i], free_margin, max_range)
            clip = _clip_ray_through(
                ox, oy, oz, end_g[i, 0], end_g[i, 1], end_g[i, 2], nx, ny, nz, t_limit
            )
        else:
            continue
        walk, sx, sy, sz, dx, dy, dz, inv_d, cx, cy, cz, ex, ey, ez, extra_visit = clip
        if not walk:
            continue
        ix0 = min(ix0, cx, ex)
        ix1 = max(ix1, cx, ex)
        iy0 = min(iy0, cy, ey)
        iy1 = max(iy1, cy, ey)
        rem_x = abs(ex - cx)
        rem_y = abs(ey - cy)
        rem_z = abs(ez - cz)
        tmx, tdx = _first_crossing(rem_x, dx, inv_d[0], sx, cx)
        tmy, tdy = _first_crossing(rem_y, dy, inv_d[1], sy, cy)
        tmz, tdz = _first_crossing(rem_z, dz, inv_d[2], sz, cz)
        idx = cx * stride_x + cy * stride_y + cz
        dix = (1 if ex > cx else -1) * stride_x
        diy = (1 if ey > cy else -1) * stride_y
        diz = 1 if ez > cz else -1
        # The nearest crossing first (ties: x, then y, then z); an axis without crossings left
        # never wins. Tested on the counts, not with an infinite parameter: that select would
        # sit on the loop's dependency chain and compile CPU-dependently (see `_walk_columns`).
        for _ in range(rem_x + rem_y + rem_z + extra_visit):
            # Written out, not a helper call: passing the arrays to an njit helper in this loop
            # costs reference counting per cell (measured 2.5x slower; 9x when inlined).
            byte = miss_base + (idx >> 3)
            bit = np.uint8(1 << (idx & 7))
            if not mark[byte] & bit:
                mark[byte] |= bit
                if not mark[idx >> 3] & bit:  # not already listed as a hit
                    touched[n_touched] = idx
                    n_touched += 1
            if rem_x > 0 and (rem_y == 0 or tmx <= tmy) and (rem_z == 0 or tmx <= tmz):
                idx += dix
                rem_x -= 1
                tmx += tdx
            elif rem_y > 0 and (rem_z == 0 or tmy <= tmz):
                idx += diy
                rem_y -= 1
                tmy += tdy
            elif rem_z > 0:
                idx += diz
                rem_z -= 1
                tmz += tdz
    # Pass 3: apply the table lookups, clear the marks.
    for t in range(n_touched):
        idx = touched[t]
        if mark[idx >> 3] & np.uint8(1 << (idx & 7)):  # hit this frame: the hit wins
            flat[idx] = hit_table[flat[idx]]
        else:
            flat[idx] = miss_table[flat[idx]]
    mark[:] = 0
    return (
        used,
        dropped_nonfinite,
        dropped_outside,
        beyond_range,
        n_touched,
        ix0,
        ix1 + 1,
        iy0,
        iy1 + 1,
    )


def traversed_cells(
    points: NDArray[np.float64],
    sensor_origin: NDArray[np.float64],
    geometry_args: tuple[float, float, float, float, float],
    shape: tuple[int, int, int],
    free_margin_m: float = 0.0,
    columns: bool | None = None,
    max_range_m: float = np.inf,
    clear_outside: bool = False,
    discretize: bool = False,
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Cells (flat indices) a frame marks as miss and as hit — for tests and inspection.

    Runs the insertion on a scratch grid with tables that encode the mark in the level.

    Args:
        points: (N, 3) world points [m].
        sensor_origin: (3,) world sensor position [m].
        geometry_args: (origin_x, origin_y, z_min, cell, layer) [m].
        shape: (nx, ny, nz) of the grid.
        free_margin_m: As `MapperParams.free_margin_m`.
        columns: Use `insert_frame_columns` (True) or `insert_frame` (False); None: as the
            mapper chooses (columns when ``nz <= MAX_COLUMN_LAYERS``).
        max_range_m: As `MapperParams.max_range_m`.
        clear_outside: As `MapperParams.clear_outside`.
        discretize: As `MapperParams.discretize_rays`.
    """
    og = np.full(shape, 128, dtype=np.uint8)
    tables = (np.full(256, 2, dtype=np.uint8), np.full(256, 1, dtype=np.uint8))
    options = (free_margin_m, max_range_m, clear_outside, discretize)
    insert_with_scratch(points, sensor_origin, geometry_args, og, tables, options, columns)
    flat = og.reshape(-1)
    return np.flatnonzero(flat == 1), np.flatnonzero(flat == 2)


def insert_with_scratch(
    points: NDArray[np.float64],
    sensor_origin: NDArray[np.float64],
    geometry_args: tuple[float, float, float, float, float],
    og: NDArray[np.uint8],
    tables: tuple[NDArray[np.uint8], NDArray[np.uint8]],
    options: tuple[float, float, bool, bool],
    columns: bool | None = None,
) -> tuple[tuple, NDArray[np.int64]]:
    """One frame into ``og`` by either kernel with fresh scratch — for tests and inspection.

    Args:
        points: (N, 3) world points [m].
        sensor_origin: (3,) world sensor position [m].
        geometry_args: (origin_x, origin_y, z_min, cell, layer) [m].
        og: (nx, ny, nz) uint8 levels, updated in place.
        tables: (hit, miss) tables (`lookup_tables`).
        options: (free_margin_m, max_range_m, clear_outside, discretize) as in `insert_frame`.
        columns: As in `traversed_cells`.

    Returns:
        (the kernel's result tuple, the points' ``point_cell`` codes).
    """
    nx, ny, nz = og.shape
    hit, miss = tables
    pts = np.ascontiguousarray(points, dtype=np.float64)
    origin = np.ascontiguousarray(sensor_origin, dtype=np.float64)
    point_cell = np.empty(pts.shape[0], dtype=np.int64)
    free_margin_m, max_range_m, clear_outside, discretize = options
    cells = cell_set(len(pts)) if discretize else None
    kernel_options = (free_margin_m, max_range_m, clear_outside, cells)
    if columns is None:
        columns = nz <= MAX_COLUMN_LAYERS
    if columns:
        dtype = column_mask_dtype(nz)
        scratch = (np.zeros(nx * ny, dtype=dtype), np.zeros(nx * ny, dtype=dtype))
        result = insert_frame_columns(
            pts,
            origin,
            *geometry_args,
            og,
            *scratch,
            layer_range_masks(nz),
            update_table(hit, miss),
            point_cell,
            *kernel_options,
        )
    else:
        size = nx * ny * nz
        scratch = (np.zeros(mark_buffer_size(size), dtype=np.uint8), np.zeros(size, np.int64))
        result = insert_frame(
            pts, origin, *geometry_args, og, *scratch, hit, miss, point_cell, *kernel_options
        )
    return result, point_cell


# ---------------------------------------------------------------- column kernel (nz <= 64)
#: Largest ``nz`` the column kernel handles (one bit per layer in a uint64 word).
MAX_COLUMN_LAYERS = 64
#: ``log2(MAX_COLUMN_LAYERS)``: the row shift of `layer_range_masks`.
_LAYER_BITS = 6


def column_mask_dtype(nz: int) -> np.dtype:
    """Smallest unsigned integer type with one bit per layer of a column (``nz <= 64``)."""
    for dtype in (np.uint8, np.uint16, np.uint32, np.uint64):
        if nz <= 8 * np.dtype(dtype).itemsize:
            return np.dtype(dtype)
    raise ValueError(f"nz must be <= {MAX_COLUMN_LAYERS} for column masks, got {nz}")


def layer_range_masks(nz: int) -> NDArray:
    """Flat table of the layer runs: ``masks[a * 64 + b]`` has layers ``min(a, b) … max(a, b)``.

    ``(nz * MAX_COLUMN_LAYERS,)`` words (`column_mask_dtype`), read by `_range_mask`. A row of
    64 entries whatever ``nz``: the index is a shift and an add, where a ``(nz, nz)`` table's
    runtime stride costs a multiplication and reloads on every crossing of the walk (the
    stage's insert 3 % faster compiled for the host, the same with ``generic``).
    """
    dtype = column_mask_dtype(nz)
    masks = np.zeros(nz * MAX_COLUMN_LAYERS, dtype=dtype)
    for a in range(nz):
        for b in range(nz):
            lo, hi = min(a, b), max(a, b)
            masks[(a << _LAYER_BITS) + b] = sum(1 << k for k in range(lo, hi + 1))
    return masks


@numba.njit(cache=True, inline="always")
def _range_mask(range_masks, a, b):
    """The word with layers ``min(a, b) … max(a, b)`` set (``a, b`` in ``0 … nz - 1``)."""
    return range_masks[(np.uint64(a) << np.uint64(_LAYER_BITS)) + np.uint64(b)]


def update_table(hit_table: NDArray[np.uint8], miss_table: NDArray[np.uint8]) -> NDArray[np.uint8]:
    """(3, 256) table indexed by (state, old level): state 0 = untouched, 1 = miss, 2 = hit."""
    return np.stack([np.arange(LEVELS, dtype=np.uint8), miss_table, hit_table])


@numba.njit(cache=True, inline="always")
def _walk_columns(miss_cols, range_masks, c, z_entry, axis_x, axis_y, z_line, z_range):
    """Mark the layers a ray crosses in each column it leaves; returns (last column, entry layer).

    Each axis is ``(crossings left, parameter of the next crossing, parameter step, column
    step)``: the ray leaves column ``c`` (flat ``ix*ny + iy``) ``rem_x`` times across an x
    boundary, at ray parameters ``tmx, tmx + tdx, ...`` (``_first_crossing``), likewise in y.
    Each column holds the layers from its entry layer to the layer at its exit: ``z = sz +
    t·dz`` with ``z_line = (sz, dz)``, clamped to ``z_range = (z_lo, z_hi)``. While both axes
    have crossings left the nearer one comes first (x wins ties, as in `insert_frame`); then the
    other axis's crossings follow in order. Two loops instead of one with an infinite parameter
    for an exhausted axis: that select sits on the loop's dependency chain, and how it is
    compiled depends on the CPU (2x slower with AVX-512 than with the ``generic`` target).

    Measured alternatives, all slower on the stage's frames (Intel Xeon, the insert alone,
    0.52 ms a frame with this walk: 141 k column steps, 107 k of them along the ray's major
    axis): one step per major-axis crossing with the minor crossing taken by a branch-free
    select (the same marks; 1.2 ms host, 0.79 ms ``generic``: the comparison and the select sit
    on the loop's dependency chain) or located from the position ``floor(s + t·d)`` with no
    chain at all (0.73 ms: more instructions a step than the mispredictions cost); a single
    loop over all crossings (0.53 ms). Without the layer computation the walk would take
    0.085 ms less, without the OR 0.035 ms less: the branch on the nearer crossing and the
    loop's exits (one a ray, 5 900 rays) take most of the rest. Walking 8 (or 32) rays in
    lock step, branch-free (selects; the same marks), took 1.03 (1.2) ms instead of 0.52: LLVM
    does not vectorize the loop over the rays, and its scalar selects cost more than the
    mispredictions they avoid. Each axis's crossings (parameter, layer) first written to a list
    per ray, then the two sorted lists merged branch-free with an ``inf`` sentinel (the same
    floats, the same marks): the insert 18 to 22 % slower (Intel Xeon, load 12-16, host), the
    merge's chain (list position, load, compare) costing more than the mispredictions. Rays
    prepared in chunks of 64 (classification, clipping, first crossings) before they are
    walked, so that their divisions overlap: no faster (the walk is about 80 % of the insert,
    the per-ray arithmetic 11 %, the table lookups 9 %: one run with parts left out, load 19).
    The rays' order does not matter to the marks (the OR commutes):
    sorted by azimuth the walk is 4 % faster, less than a sort costs; shuffled 10 % slower.

    Run-slice walks (issue #14), each giving the same marks, are no faster (the insert's
    speed relative to this walk, host / ``generic``, interleaved over stage seed 1's 832
    frames; Intel Xeon, load 7-10; stage_zigzag seed 2 alike). (1) The major axis's crossings
    up to the next minor one as an inner loop, with the same comparisons: 0.98 / 0.96.
    (2) Its first ``floor(tdb / tda) - 1`` steps after each minor crossing taken without a
    comparison (a counted loop): 0.95 / 0.93. (3) The minor crossings' places among the
    major ones computed per ray first (``floor((t_b - t_a0) / tda) + 1`` with the accumulated
    ``t_b``; a ray with a crossing within 1e-10 of a tie left to this walk, none on the
    stage), then one branch-free step per major crossing (an optional minor column, two ORs):
    0.98-0.99 / 0.975. That loop alone is 16 % faster than this walk, but the schedule costs as
    much (0.083 ms a frame for 33 k minor crossings, with its loop's exit once a ray). The
    bound: with the branch on the nearer crossing replaced by a predictable pattern (wrong
    marks) the insert is 1.36× (1.34× ``generic``) faster; every exact branch-free
    replacement tried costs as much as the mispredictions it avoids. Numba note from (3):
    arrays passed to an inlined helper called inside a branch (or with early returns) are
    reference-counted once a ray (``NRT_incref`` calls in the kernel's assembly; 0.1 ms a
    frame): written out in the kernel, they were not.

    What sharing could save: on the stage's frames 92 % of the ORs add no bit at 88 × 72 (98 %
    at 176 × 144), but only 26 % of the rays add none at all (65 % at 176 × 144): most rays
    add a few cells near their ends, so skipping whole rays, even with a free test, would
    save at most a quarter of the walk at 88 × 72.

    Walking each ray backward, from its stop toward the sensor, and leaving it after ``K``
    columns in a row whose run adds no bit to the frame's marks (hits counted, all hits set
    first; rays from one point converge toward the sensor, so a ray covered there is likely
    covered beyond): session 43, stage depth seed 1, 300 frames, each frame from the exact
    insertion's grid (AMD EPYC, host): the exact forward walk 0.564 ms; backward without a
    stop 0.849 ms (the same marks: the coverage test and the second pass over the points);
    ``K`` = 1 / 2 / 3 / 4 / 6: 0.337 / 0.430 / 0.505 / 0.562 / 0.633 ms, with 483 / 108 /
    30 / 9.1 / 2.7 cells a frame at another level than the exact insertion (84 / 39 / 15 / 8
    / 0 occupied states over the 300 frames). Neighbouring rays differ by a layer in many
    columns near the sensor, so no ``K`` is both faster and close to exact.
    """
    rem_x, tmx, tdx, dcol_x = axis_x
    rem_y, tmy, tdy, dcol_y = axis_y
    sz, dz = z_line
    # Clamped as floats, then truncated: the layer of truncating and then clamping the integer
    # (int() truncates, floor() rounds down: they differ only below 0, where the clamp to
    # z_lo >= 0 makes both 0), but minsd/maxsd instead of the integer compares LLVM compiles to
    # branches in this loop (the stage's insert 8 % faster, host and generic codegen).
    z_lo = float(z_range[0])
    z_hi = float(z_range[1])
    # The step written out in each branch, not a parameter selected and one step after the if:
    # the select made LLVM move the two parameters between registers on every crossing (26
    # instructions a crossing, 20 written out; the stage's insert 5.6 % faster host, 12 %
    # generic at 88 x 72, 5.8 % host at 176 x 144; the same marks).
    # The indices are non-negative: unsigned, so numba adds no negative-index wraparound.
    while rem_x > 0 and rem_y > 0:
        if tmx <= tmy:
            z_exit = int(min(max(sz + tmx * dz, z_lo), z_hi))
            miss_cols[np.uint64(c)] |= _range_mask(range_masks, z_entry, z_exit)
            z_entry = z_exit
            c += dcol_x
            tmx += tdx
            rem_x -= 1
        else:
            z_exit = int(min(max(sz + tmy * dz, z_lo), z_hi))
            miss_cols[np.uint64(c)] |= _range_mask(range_masks, z_entry, z_exit)
            z_entry = z_exit
            c += dcol_y
            tmy += tdy
            rem_y -= 1
    if rem_x > 0:
        t_exit, t_step, rem, step = tmx, tdx, rem_x, dcol_x
    else:
        t_exit, t_step, rem, step = tmy, tdy, rem_y, dcol_y
    for _ in range(rem):
        z_exit = int(min(max(sz + t_exit * dz, z_lo), z_hi))
        miss_cols[np.uint64(c)] |= _range_mask(range_masks, z_entry, z_exit)
        z_entry = z_exit
        c += step
        t_exit += t_step
    return c, z_entry


@numba.njit(cache=True, inline="always")
def _repeat_start(clip, sensor_grid, shape, free_margin, length_m, columns):
    """`_clip_ray`'s result moved to start about ``columns`` columns before the stop.

    For a ray whose end cell an earlier ray of the frame already hit (`insert_frame_columns`
    with ``repeat_columns``): the new start is the point ``columns / max(|dx|, |dy|)`` before
    the stop along the segment (grid units), used only when it lies after the ray's entry into
    the grid (fewer column steps to the stop); else the clip is returned unchanged.
    """
    walk, _, _, _, dx, dy, dz, inv_d, cx, cy, _, ex, ey, ez, stop_cleared = clip
    if not walk:
        return clip
    ox, oy, oz = sensor_grid
    nx, ny, nz = shape
    steps = abs(ex - cx) + abs(ey - cy)
    if steps <= columns:
        return clip
    t_stop = 1.0 - free_margin / length_m if free_margin > 0.0 else 1.0
    t_s = t_stop - columns / max(abs(dx), abs(dy))
    if t_s <= 0.0:
        return clip
    nsx = ox + t_s * dx
    nsy = oy + t_s * dy
    nsz = oz + t_s * dz
    if not (0.0 <= nsx < nx and 0.0 <= nsy < ny and 0.0 <= nsz < nz):
        return clip
    ncx = _clamped_cell(nsx, nx)
    ncy = _clamped_cell(nsy, ny)
    ncz = _clamped_cell(nsz, nz)
    if abs(ex - ncx) + abs(ey - ncy) >= steps:
        return clip
    return walk, nsx, nsy, nsz, dx, dy, dz, inv_d, ncx, ncy, ncz, ex, ey, ez, stop_cleared


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy", boundscheck=False)
def insert_frame_columns(
    points: NDArray[np.float64],
    sensor_origin: NDArray[np.float64],
    origin_x: float,
    origin_y: float,
    z_min: float,
    cell: float,
    layer: float,
    og: NDArray[np.uint8],
    hit_cols: NDArray,
    miss_cols: NDArray,
    range_masks: NDArray,
    table: NDArray[np.uint8],
    point_cell: NDArray[np.int64],
    free_margin: float = 0.0,
    max_range: float = np.inf,
    clear_outside: bool = False,
    cells: tuple[NDArray[np.int64], NDArray[np.int8]] | None = None,
    repeat_columns: int = 0,
):
    """`insert_frame` with the marks kept as one bit per layer in one word per column.

    The same once-per-frame rule and the same cells as `insert_frame` (exact traversal of the
    clipped segment), but the walk only stops at x/y cell boundaries: the layers a ray crosses
    inside one column are a contiguous run, from the layer where it enters the column to the
    layer where it leaves it (``floor`` of z at the boundary), marked by OR-ing one range mask
    into the column's word. Rays whose path touches a layer boundary exactly where they cross a
    column boundary (measure zero) may mark that zero-length layer in the other column than
    `insert_frame` does; every cell the segment crosses with positive length is marked by
    both. Faster than `insert_frame` (one step per column, no per-cell bit test); the table
    lookups then run over the affected area's words.

    Args:
        points: (N, 3) world points [m].
        sensor_origin: (3,) world sensor position [m].
        origin_x: World x of the grid's corner [m].
        origin_y: World y of the grid's corner [m].
        z_min: World z of the grid's lowest face [m].
        cell: Cell side [m].
        layer: Layer height [m].
        og: (nx, ny, nz) uint8 levels, updated in place.
        hit_cols: (nx*ny,) unsigned scratch (``column_mask_dtype(nz)``), all zero on entry and
            on return: bit ``k`` of word ``ix*ny + iy`` marks layer ``k`` of that column hit.
        miss_cols: Same for "crossed by a ray" (the hit wins where both are set).
        range_masks: ``layer_range_masks(nz)``.
        table: ``update_table(hit_table, miss_table)``.
        point_cell: (N,) out: the point's column index ``ix*ny + iy`` or a no-hit code, as
            in `insert_frame`.
        free_margin: Rays stop clearing this far [m] before their end point.
        max_range: As in `insert_frame` [m].
        clear_outside: As in `insert_frame`.
        cells: As in `insert_frame`.
        repeat_columns: 0: every ray is walked whole (exact). ``k > 0``: a ray whose end cell
            an earlier ray of the frame already hit walks only its last columns, from about
            ``k`` columns before its stop (`_repeat_start`; `MapperParams.repeat_ray_columns`).

    Returns:
        As `insert_frame`.
    """
    nx, ny, nz = og.shape
    flat = og.reshape(-1)
    dropped_nonfinite = 0
    dropped_outside = 0
    beyond_range = 0
    used = 0
    geometry = (origin_x, origin_y, z_min, cell, layer)
    shape = (nx, ny, nz)
    need_length = free_margin > 0.0 or max_range < np.inf
    ox = (sensor_origin[0] - origin_x) / cell
    oy = (sensor_origin[1] - origin_y) / cell
    oz = (sensor_origin[2] - z_min) / layer
    ix0 = nx
    ix1 = np.int64(-1)  # not the literal -1: _apply_columns would compile for both
    iy0 = ny
    iy1 = np.int64(-1)
    for i in range(points.shape[0]):
        status, gx, gy, gz, ix, iy, iz, length = _classify(
            points[i, 0],
            points[i, 1],
            points[i, 2],
            sensor_origin[0],
            sensor_origin[1],
            sensor_origin[2],
            geometry,
            shape,
            need_length and cells is None,
            max_range,
        )
        cast = True
        if cells is not None:  # pruned by numba when None: compiled only for discretizing
            end = (status, gx, gy, gz, ix, iy, iz, length)
            cast, status, gx, gy, gz, ix, iy, iz, length = _discretized(
                cells, end, (ox, oy, oz), (cell, layer), shape, need_length, max_range
            )
        if status < 0:
            dropped_nonfinite += status == NONFINITE
            dropped_outside += status == OUTSIDE
            beyond_range += status == BEYOND_RANGE
            point_cell[i] = status
            if not cast or not clear_outside or status == NONFINITE:
                continue
            t_limit = _no_hit_limit(status, length, free_margin, max_range)
            clip = _clip_ray_through(ox, oy, oz, gx, gy, gz, nx, ny, nz, t_limit)
        else:
            point_cell[i] = ix * ny + iy
            used += 1
            ix0 = min(ix0, ix)
            ix1 = max(ix1, ix)
            iy0 = min(iy0, iy)
            iy1 = max(iy1, iy)
            column = np.uint64(ix * ny + iy)
            end_bit = _range_mask(range_masks, iz, iz)
            repeat = (hit_cols[column] & end_bit) != 0
            hit_cols[column] |= end_bit
            if not cast:
                continue
            clip = _clip_ray(ox, oy, oz, gx, gy, gz, ix, iy, iz, nx, ny, nz, free_margin, length)
            if repeat and repeat_columns > 0:
                clip = _repeat_start(clip, (ox, oy, oz), shape, free_margin, length, repeat_columns)
        walk, sx, sy, sz, dx, dy, dz, inv_d, cx, cy, cz, ex, ey, ez, stop_cleared = clip
        if not walk:
            continue
        # Two-argument min/max: numba's three-argument overloads are compiled on their own.
        ix0 = min(min(ix0, cx), ex)
        ix1 = max(max(ix1, cx), ex)
        iy0 = min(min(iy0, cy), ey)
        iy1 = max(max(iy1, cy), ey)
        rem_x = abs(ex - cx)
        rem_y = abs(ey - cy)
        tmx, tdx = _first_crossing(rem_x, dx, inv_d[0], sx, cx)
        tmy, tdy = _first_crossing(rem_y, dy, inv_d[1], sy, cy)
        c, z_entry = _walk_columns(
            miss_cols,
            range_masks,
            cx * ny + cy,
            cz,
            (rem_x, tmx, tdx, ny if ex > cx else -ny),
            (rem_y, tmy, tdy, 1 if ey > cy else -1),
            (sz, dz),
            (min(cz, ez), max(cz, ez)),
        )
        # The last column: its layers down to the end (or stop) cell. The end cell itself is
        # only marked when it is a stop cell (an end cell is hit, and the hit wins anyway).
        if stop_cleared:
            miss_cols[np.uint64(c)] |= _range_mask(range_masks, z_entry, ez)
        elif z_entry != ez:
            z_before_end = ez - 1 if ez > z_entry else ez + 1
            miss_cols[np.uint64(c)] |= _range_mask(range_masks, z_entry, z_before_end)
    n_touched = _apply_columns(flat, nz, ny, hit_cols, miss_cols, table, ix0, ix1, iy0, iy1)
    return (
        used,
        dropped_nonfinite,
        dropped_outside,
        beyond_range,
        n_touched,
        ix0,
        ix1 + 1,
        iy0,
        iy1 + 1,
    )


#: De Bruijn sequence of `_lowest_bit`: ``(b * _DE_BRUIJN) >> 58`` differs for every ``b = 2**k``.
_DE_BRUIJN = np.uint64(0x03F79D71B4CB0A89)


def _de_bruijn_positions() -> NDArray[np.uint8]:
    """``positions[(2**k * _DE_BRUIJN) >> 58] = k`` for ``k = 0 … 63`` (`_lowest_bit`)."""
    positions = np.zeros(64, dtype=np.uint8)
    for k in range(64):
        positions[((1 << k) * int(_DE_BRUIJN) % 2**64) >> 58] = k
    return positions


_BIT_POSITIONS = _de_bruijn_positions()


@numba.njit(cache=True, inline="always")
def _lowest_bit(word):
    """(the lowest set bit of a non-zero ``word`` as a word, its index ``k``).

    Isolated by ``word & -word`` and located by a De Bruijn multiplication and a 64-entry table:
    portable (numba has no count-trailing-zeros), the same on every CPU and codegen.
    """
    bit = word & (~word + np.uint64(1))
    return bit, _BIT_POSITIONS[(bit * _DE_BRUIJN) >> np.uint64(58)]


@numba.njit(cache=True, inline="always")
def _apply_bits(flat, base, word, table, row: int) -> int:
    """Apply table row ``row`` (1 = miss, 2 = hit) to the layers set in a column's ``word``.

    The column starts at flat index ``base``. Returns how many cells were updated.
    """
    n = 0
    while word != 0:
        bit, k = _lowest_bit(word)
        idx = base + np.uint64(k)
        flat[idx] = table[row, flat[idx]]
        word ^= bit
        n += 1
    return n


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, boundscheck=False, error_model="numpy")
def _apply_columns(flat, nz, ny, hit_cols, miss_cols, table, ix0, ix1, iy0, iy1) -> int:
    """Table lookups for the marked layers in ``[ix0, ix1] × [iy0, iy1]``; clears the marks.

    Only the set bits of a column's words are visited (`_lowest_bit`), not all ``nz`` layers
    with a test each (the stage's insert 4.5 % faster compiled for the host, 1.5 % ``generic``;
    Intel Xeon, load 22, A/B as in `bench/bench_insert_ab.py` over seed 1's frames: 832 host,
    300 ``generic``).

    Returns:
        How many cells were updated.
    """
    n_touched = 0
    for ix in range(ix0, ix1 + 1):
        for iy in range(iy0, iy1 + 1):
            col = np.uint64(ix * ny + iy)
            hit = np.uint64(hit_cols[col])
            miss = np.uint64(miss_cols[col])
            if (hit | miss) == 0:
                continue
            hit_cols[col] = 0
            miss_cols[col] = 0
            miss = miss & ~hit
            base = col * np.uint64(nz)
            n_touched += _apply_bits(flat, base, hit, table, 2)
            n_touched += _apply_bits(flat, base, miss, table, 1)
    return n_touched
