"""Limits on what the library accepts: every resource and coordinate bound, in one place.

Each bound keeps a value the type and sign checks would pass from exhausting memory or time,
or from silently meaning nothing (a grid whose every point lies outside it). Each is far above
what the paper's robot or any depth camera needs; the docstrings say why the number.
"""

MAX_COORDINATE_M = 1e8
"""Largest magnitude of a world coordinate [m] the mapper takes (grid centre, sensor origin,
points, floor heights, ``z_min_m``). Larger than any Earth-fixed frame (ECEF coordinates reach
6.4e6 m, UTM northings 1e7 m), while float64 still resolves 15 nm there, far below
`MIN_CELL_M`, and the grid's integer lattice index (at most ``1e8 / MIN_CELL_M = 1e11``) stays
exact. Beyond it, ``recenter`` would scroll the maps by more cells than an int64 holds and the
kernels' float-to-int casts would overflow."""

MIN_CELL_M = 0.001
"""Smallest cell side and layer height [m]. A cell finer than the depth noise of the best depth
cameras (about 1 mm at 0.5 m) cannot hold a surface: its points scatter over many cells. A
``cell_m`` of 1e-9 would make a grid of 100 cells 0.1 µm wide, with every point outside it."""

MAX_CELL_M = 1.0
"""Largest cell side and layer height [m]: 25 of the paper's 4 cm cells. A column holds one floor
and one obstacle height, so a cell wider than a humanoid's stride (or a layer taller than a
table) hides every step and obstacle it covers; a ``cell_m`` of 1e9 puts the whole world into
one cell."""

MAX_COLUMNS = 2**22
"""Most (x, y) columns of a grid, ``nx * ny`` (2048 × 2048: 82 m square at the paper's 4 cm;
the paper's map has 100 × 100). Each column holds about 41 bytes of 2D maps (floor, obstacle
and FOG heights as float64, the FOG label, two mark words of at most 8 bytes), 172 MB at the
limit; a 20000 × 20000 grid would need 16 GB."""

MAX_CELLS = 2**26
"""Most 3D cells, ``nx * ny * nz`` (2048 × 2048 × 16; the paper's grid has 160000). The
occupancy grid stores one byte per cell (64 MiB at the limit); the per-cell marking kernel used
when ``nz > 64`` adds 8.25 bytes of scratch per cell (about 0.55 GB at the limit)."""

MAX_SEGMENTATION_PASSES = 64
"""Most rounds of each iterative step of the segmentation (``break_passes``,
``reassign_passes``, ``fill_passes``). Every round sweeps the whole image; the defaults use
2 or 3 and the steps converge in a few (a fill round spreads planes by one pixel, so 64 rounds
reach 64 pixels into leftover regions, which are a few pixels wide). 64 rounds of a 640 × 480
image take well under a second."""

MAX_WINDOW_PX = 64
"""Largest half width [px] of the segmentation's windows (``noise_window_px``,
``edge_window_px``, ``break_reach_px``): their cost per pixel grows with the width. 64 is wider
than the paper's 72-row images are tall, and ten times the defaults (3 to 6)."""

MAX_IMAGE_SIDE_PX = 16384
"""Largest width or height [px] of a depth image (`mapper.intrinsics.PinholeIntrinsics`): four
times the widest depth sensors (4096 px)."""

MAX_IMAGE_PIXELS = 2**24
"""Most pixels of a depth image, ``width * height`` (4096 × 4096, three times the largest
structured-light depth sensors' 5 MP). The segmentation keeps a table of 3 float64 ray
components per pixel (384 MiB at the limit) and a few per-pixel images of the same size."""

RIGID_TOLERANCE = 1e-6
"""Largest deviation ``max |R·Rᵀ − I|`` of a rigid transform's rotation from orthonormality.
A rotation rounded through float32 (as recordings may store it) deviates by about 1e-7; a
rotation off by more than 1e-6 is not one (a shear or scale of 1e-6 moves a point at 10 m by
10 µm, and anything larger is an error of the caller)."""
