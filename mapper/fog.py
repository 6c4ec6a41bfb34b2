"""Obstacle height (eq. 10), floor and obstacle grid (eq. 11) and ceiling map (Sec. VI).

Conventions (heights in world metres, NaN = invalid):

- ``Obstacle(x, y)`` is the *top face* of the highest occupied cell of the column,
  ``z_min + (k + 1)·layer`` — the coarse upper bound of what is there.
- FOG: obstacle if ``h_o > h_f + δ`` (with an invalid floor every valid ``h_o`` counts), else
  floor if ``h_f`` is valid, else unknown. Beyond the paper, a floor whose points do not cover
  its cell (`mapper.floor_cover`, `MapperParams.floor_pass_fraction`) counts as invalid here.
  Obstacles below the floor surface are ignored; an
  occupied cell hanging above a floor (curtain, table top) makes the cell an obstacle.
  Beyond the paper, with a margin of ``m`` cells (`MapperParams.obstacle_margin_cells`) eq. 11
  compares the floor with the highest ``h_o`` over the ``(2m + 1)²`` cells around it: a floor
  beside something more than δ above it — a box, the top of a step or sill whose edge may lie
  inside this cell — is an obstacle with that height (0 = the paper).
- Beyond the paper, a floor beside an edge is unknown: when one of its 8 neighbours is an
  obstacle more than δ above it that is no higher floor's edge
  (`MapperParams.unknown_beside_obstacles`; a step's edge cell, whose top is the layer of a
  stored floor within a cell of it, leaves the tread at its foot a floor), or a floor more than
  `MapperParams.edge_band_m` below it (the rim of a raised surface; both as eq. 11 and the
  cover check label the neighbour), or, with the band, a cell where nothing is stored (no
  floor, no obstacle) with such a lower floor beside it: the ground hidden behind a raised
  surface's side edge, seen from on top or beside it, is never seen, and the rim's points
  spilled over the edge make the cell before that shadow the raised floor's. The edge lies
  within a cell of their common boundary, but the camera pose's error (1–4 cm at the stage's
  ranges) and the segmentation's snapping move a surface's points a cell either way from frame
  to frame, so the map cannot tell which of the two cells holds it — and a cell an edge crosses
  is no floor to step on (its riser or the obstacle's side is in it). Eq. 9 keeps the highest
  surface, so the cell an edge crosses takes the higher floor's height: the higher side's rim
  is the unsafe one, the lower side's cell at the riser's foot is floor or (by the layer rule)
  an obstacle.
- Beyond the paper, with the band, a floor at the foot of a narrow rise is unknown too
  (`MapperParams.narrow_rise_m`): its neighbour along x or y is a floor more than the band
  above it on a surface two to n cells deep that drops again beyond (a sill, a low box). The
  lower side's cell may hold the riser as well (a sill's far edge cell: 1 cm of sill, 3 cm of
  ground), and its points do not tell (the higher surface spills a quarter of a cell's points
  over a riser on the cell boundary too); a walker steps over such a rise, so only there are
  both sides given up, never at the foot of a tread that leads to a higher one. A cell never
  seen (nothing stored) ends the raised surface as a drop does (it is no deeper than seen),
  and the near rim of a narrow rise whose foot holds no floor (never seen, or only its edge)
  is unknown too: the rim rule finds no lower floor there.
- Beyond the paper, with the band and `MapperParams.rim_over_spill`, the rim rule also counts
  a neighbour labelled obstacle whose stored floor lies more than the band below and whose
  top reaches no higher than the floor + δ (a lower surface under the raised surface's own
  spill: the edge cell, or the ground beside a side edge spilled a cell over) — when the
  raised floor ends across from it (`_patch_across`): the cell on the other side holds no
  floor and its top lies within δ above the floor (the surface's layer: a rough top's column,
  a box's edge), or, along
  x or y, a lower floor (a single raised cell). A riser's edge cell holds the lower tread's
  floor under the upper tread's layer just as a side spill's does; what tells them apart is
  the upper tread going on across from it, so a tread's first row stays a floor.
- Beyond the paper, with the band, a floor before a wider shadow is unknown too
  (`MapperParams.shadow_reach_m`): a run of up to n cells with nothing stored leads from it,
  along x, y or a diagonal, to a floor more than the band below it. Pose drift (the zig-zag
  stage: odometry 4 cm and 1° off by the staircase, the heading 1° off) spills a raised
  surface one or two cells over its side edge, into the shadow behind that edge, which is
  several cells wide (``D·H/(Z − H)`` for a surface H high seen from Z at range D).
- Beyond the paper, with the band and `MapperParams.rim_over_seen_drop`, a floor at ``h`` is
  unknown beside a cell where nothing is stored whose column was observed free in a layer
  more than the band below ``h``: rays passed there under the surface, so it does not go
  on — the rim before a drop whose bottom was never seen (a shadow wider than
  ``shadow_reach_m``, or one no seen lower floor ends), which the rules above, all looking
  for a lower floor, miss.
- Beyond the paper, with the band and `MapperParams.min_floor_neighbours` k > 0, a floor the
  rules above leave a floor is unknown when fewer than k of its 8 neighbours are such floors
  within the band of it and one is an obstacle taller than it: a one- or two-cell plane
  fitted to a rough top's lower part (off by default).
- Beyond the paper, with `MapperParams.ground_noise_unknown`, a cell eq. 11 makes an obstacle is
  unknown when its top lies within δ above the lowest floor around it (of its 8 neighbours, at
  least 3 that eq. 11 leaves floors): its own floor is missing (far ground the segmentation
  left unlabelled fills the ground's layer with hits) or lower than every neighbour's (a
  stereo outlier), nothing in it stands on the floor. Only the output is relabelled: the rules
  above see eq. 11's obstacle, so a rim beside it stays unknown and no floor is added.
- Beyond the paper, with `MapperParams.min_floor_frames` n > 1, after every rule above, a
  floor fewer than n frames have seen as a plane (its frame votes) is unknown when no
  neighbour holds a confirmed floor of its height and two opposite neighbours hold no floor
  and a top reaching its level: a rough top's level patch that one frame's noise let through
  (`mark_unconfirmed_floors`). Only the output is relabelled.
- ``Ceiling(x, y)`` is the *bottom face* of the lowest occupied cell above the free space a
  robot could use: where the floor is valid, the lowest occupied cell whose top is above
  ``h_f + δ`` (the cells the FOG counts as obstacle); where it is not, the lowest occupied cell
  with a cell observed free (``OG < 0.5``) somewhere below it in its column (something seen
  overhanging). NaN where there is none. ``ceiling − floor`` is the clearance to crawl under.
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

from mapper.grid import CellType
from mapper.params import LEVEL_UNKNOWN

_UNKNOWN = np.int8(CellType.UNKNOWN)
_FLOOR = np.int8(CellType.FLOOR)
_OBSTACLE = np.int8(CellType.OBSTACLE)
# `_surface_ends_within`'s constant arguments as numpy scalars: numba types a Python literal
# argument as its own type (``Literal[int](1)``) and compiles the callee once per value.
_ONE, _TWO = np.int64(1), np.int64(2)
_YES, _NO = np.bool_(True), np.bool_(False)


@numba.njit(cache=True, inline="always")
def _highest_within(obstacle: NDArray[np.float64], ix: int, iy: int, margin: int) -> float:
    """Highest ``obstacle`` within ``margin`` cells of ``(ix, iy)`` (clipped), -inf if none."""
    nx, ny = obstacle.shape
    highest = -np.inf
    for jx in range(max(ix - margin, 0), min(ix + margin + 1, nx)):
        for jy in range(max(iy - margin, 0), min(iy + margin + 1, ny)):
            near = obstacle[jx, jy]
            if near > highest:  # NaN: never
                highest = near
    return highest


_FLOORS_AROUND_NOISE = 3
"""`MapperParams.ground_noise_unknown` needs at least this many of a cell's 8 neighbours to be
floors eq. 11 leaves a floor: a cell amid a floor, not a rough top's cell beside one or two
small planes fitted to that top (replays seeds 1–8, session 32, room stereo: of the rocks' cells
the rule took from obstacle to unknown, 99 of 123 had one or two such neighbours; of the ground
cells 278 of 384 had three or more)."""


@numba.njit(cache=True, inline="always")
def _ground_noise(
    floor: NDArray[np.float64],
    obstacle: NDArray[np.float64],
    ix: int,
    iy: int,
    top: float,
    delta: float,
) -> bool:
    """Whether ``top`` lies within ``delta`` above the lowest floor around ``(ix, iy)``.

    The floors around are those of its 8 neighbours (clipped) eq. 11 leaves a floor: a floor
    stored and nothing more than ``delta`` above it; at least `_FLOORS_AROUND_NOISE` of them.
    """
    nx, ny = floor.shape
    lowest = np.inf
    count = 0
    for jx in range(max(ix - 1, 0), min(ix + 2, nx)):
        for jy in range(max(iy - 1, 0), min(iy + 2, ny)):
            near = floor[jx, jy]
            if (
                (jx != ix or jy != iy)
                and not np.isnan(near)
                and not obstacle[jx, jy] > near + delta
            ):
                count += 1
                lowest = min(lowest, near)
    return count >= _FLOORS_AROUND_NOISE and top <= lowest + delta


@numba.njit(cache=True, inline="always")
def _at_narrow_rise(
    floor: NDArray[np.float64],
    obstacle: NDArray[np.float64],
    ix: int,
    iy: int,
    h: float,
    band: float,
    delta: float,
    cells: int,
) -> bool:
    """Whether the floor ``h`` at ``(ix, iy)`` lies at the foot or the near rim of a narrow rise.

    At the foot: along x or y, its neighbour's stored floor ``t`` is more than ``band`` above
    ``h`` and, within ``cells`` cells beyond that neighbour, the stored floors (cells without
    one skipped) drop again more than ``band`` below ``t`` before any other height than
    ``t ± band`` is met, after at least two cells within ``t ± band``: a raised surface two to
    ``cells`` cells deep in that direction (a sill, a low box), whose both edges — one of them
    possibly inside this cell — lie within that distance. A cell where nothing is stored (no
    floor, no obstacle: never seen) met after those two cells ends the surface as a drop does:
    the surface is no deeper than seen, and an unseen cell is no evidence that it goes on
    (stage depth seed 5: the robot's standing place before the sill, hidden by its feet, 8
    cells without anything stored between the ground and the sill, left the sill's far edge
    cell a floor at the ground's height; stereo seed 7 the same with the box's shadow). A
    cell with an obstacle but no floor (a riser, a box's side) is skipped, as one whose floor
    a frame has not verified yet. A single cell is no such surface:
    it is a tread's points spilled a cell over the riser (stage depth seed 7: a 92 mm cell
    in step_2's last row cost that tread's cells beside it), which the rim rule leaves
    unknown.

    At the near rim before an unseen foot: along x or y, its neighbour on one side holds
    nothing (no floor, no obstacle taller than ``h + delta``) and on the other side the stored
    floors (cells without one skipped) stay within ``h ± band`` for at least one more cell
    and drop more than ``band`` below ``h`` within ``cells`` cells: the cell is the near edge
    of a raised surface at most ``cells`` deep (a sill, a low box) whose lower side there —
    where the rim rule would find the lower floor — lies in a shadow or under the robot's
    feet. Its edge may cross this cell as likely as the next (stage depth seed 7, stereo
    seeds 2–4, 7, 8: the sill's near edge cell, 1 cm of sill, took the sill's height, the
    ground before it hidden behind a box).

    Both tests scan the same 4 directions in one loop. ``floor`` and ``obstacle`` are the
    stored maps (labels not used), read directly: the grid is small and the scan short
    (module note in `_label` on helpers taking the maps).
    """
    nx, ny = floor.shape
    for d in range(4):
        dx = 1 if d == 0 else (-1 if d == 1 else 0)
        dy = 1 if d == 2 else (-1 if d == 3 else 0)
        # The foot: a raised surface from the neighbour on; a cell never seen ends it.
        jx, jy = ix + dx, iy + dy
        if 0 <= jx < nx and 0 <= jy < ny:
            top = floor[jx, jy]
            if top > h + band and _surface_ends_within(  # NaN: never
                floor, obstacle, ix, iy, dx, dy, _TWO, top, band, cells, _YES
            ):
                return True
        # The near rim: nothing behind, the surface from this cell on (unseen cells skipped).
        bx, by = ix - dx, iy - dy
        if (
            0 <= bx < nx
            and 0 <= by < ny
            and np.isnan(floor[bx, by])
            and not obstacle[bx, by] > h + delta  # NaN top: nothing
            and _surface_ends_within(floor, obstacle, ix, iy, dx, dy, _ONE, h, band, cells, _NO)
        ):
            return True
    return False


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, boundscheck=False, error_model="numpy")
def _surface_ends_within(
    floor: NDArray[np.float64],
    obstacle: NDArray[np.float64],
    ix: int,
    iy: int,
    dx: int,
    dy: int,
    first: int,
    top: float,
    band: float,
    cells: int,
    unseen_ends: bool,
) -> bool:
    """Whether a surface at height ``top`` ends within ``cells`` cells along ``(dx, dy)``.

    The scan of the narrow-rise rules: from ``(ix, iy) + first·(dx, dy)`` on, for ``cells``
    cells, the stored floors (cells without one skipped) stay within ``top ± band`` and then
    drop more than ``band`` below ``top`` — or, with ``unseen_ends``, reach a cell where
    nothing is stored (no floor, no obstacle: never seen) — after at least two cells of the
    surface, the ``first − 1`` cells before the scan's start counted as one (the surface's
    first cell, on which the caller stands or which it looked at). A height above ``top +
    band`` or the grid's border ends the scan: no such surface. A single cell is no surface.

    Args:
        floor: The stored floor map [m] (NaN: none), read directly (module note in `_label`).
        obstacle: The stored obstacle tops [m] (NaN: none).
        ix: x index of the cell the scan is about.
        iy: y index of it.
        dx: x step of the scan (-1, 0 or 1).
        dy: y step of it.
        first: The first cell scanned, in steps from ``(ix, iy)`` (1 or 2).
        top: The surface's height [m].
        band: ``edge_band_m`` [m].
        cells: How many cells are scanned (``narrow_rise_m`` in cells).
        unseen_ends: A cell never seen ends the surface (else it is skipped).
    """
    nx, ny = floor.shape
    deep = 1  # cells of the surface met, the one before the scan's start the first
    for k in range(first, cells + first):
        cx, cy = ix + k * dx, iy + k * dy
        if cx < 0 or cx >= nx or cy < 0 or cy >= ny:
            return False
        v = floor[cx, cy]
        if np.isnan(v):
            if unseen_ends and deep >= 2 and np.isnan(obstacle[cx, cy]):
                return True  # never seen: the surface ends as far as known
            continue
        if v < top - band:
            return deep >= 2
        if v > top + band:
            return False
        deep += 1
    return False


@numba.njit(cache=True, inline="always")
def _patch_across(
    floor: NDArray[np.float64],
    obstacle: NDArray[np.float64],
    ix: int,
    iy: int,
    dx: int,
    dy: int,
    h: float,
    band: float,
    delta: float,
) -> bool:
    """Whether the floor ``h`` at ``(ix, iy)`` ends across from a spilled neighbour.

    The neighbour at ``(ix, iy) − (dx, dy)`` holds a lower floor under this surface's spill
    (`MapperParams.rim_over_spill`). The raised floor ends at the cell across, ``(ix, iy) +
    (dx, dy)``, when that cell holds no floor and its top lies above ``h`` but no higher than
    ``h + delta`` (the surface's own layer, never verified as a floor: a rough top's column, a
    box's edge), or, along x or y, a floor more than ``band`` below ``h`` (a single raised
    cell between two lower floors: no surface). A cell across holding no floor and only
    layers below ``h`` (the ground's layer beside a stereo sill whose floor no frame has
    verified) ends nothing: the room's stereo sill keeps those cells. A tread's first row has
    the tread's floor across from its riser's edge cell (which holds the lower tread's floor
    under the upper tread's layer, as a side spill's cell does): it stays a floor
    (talos_course, stairs: every tread's first row). The grid's border ends nothing.
    ``floor`` and ``obstacle`` are the stored maps (module note in `_label`).
    """
    nx, ny = floor.shape
    cx, cy = ix + dx, iy + dy
    if cx < 0 or cx >= nx or cy < 0 or cy >= ny:
        return False
    across = floor[cx, cy]
    if np.isnan(across):
        top = obstacle[cx, cy]
        return h < top <= h + delta  # NaN (nothing stored): no
    return (dx == 0 or dy == 0) and across < h - band


@numba.njit(cache=True, inline="always")
def _behind_wide_shadow(
    floor: NDArray[np.float64],
    obstacle: NDArray[np.float64],
    ix: int,
    iy: int,
    h: float,
    band: float,
    cells: int,
) -> bool:
    """Whether the floor ``h`` at ``(ix, iy)`` is the rim of a raised surface behind a shadow.

    It is when, along one of the 8 directions, a run of one to ``cells`` cells where nothing
    is stored (no floor, no obstacle) starts at its neighbour and ends at a cell whose stored
    floor is more than ``band`` below ``h``: the lower surface hidden behind the raised
    surface's edge, seen from on top of it or beside it, over a shadow that many cells wide
    (the band's shadow rule reaches one cell). ``floor`` and ``obstacle`` are the stored maps
    (labels not used), read directly (module note in `_label` on helpers taking the maps).
    """
    nx, ny = floor.shape
    for dx in range(-1, 2):
        for dy in range(-1, 2):
            if dx == 0 and dy == 0:
                continue
            for k in range(1, cells + 2):
                cx, cy = ix + k * dx, iy + k * dy
                if cx < 0 or cx >= nx or cy < 0 or cy >= ny:
                    break
                v = floor[cx, cy]
                if np.isnan(v) and np.isnan(obstacle[cx, cy]):
                    continue  # nothing stored: the shadow goes on
                if k >= 2 and v < h - band:  # NaN: never
                    return True
                break
    return False


@numba.njit(cache=True, inline="always")
def _rim_over_seen_drop(
    og: NDArray[np.uint8],
    floor: NDArray[np.float64],
    obstacle: NDArray[np.float64],
    ix: int,
    iy: int,
    h: float,
    z_min: float,
    layer: float,
    band: float,
) -> bool:
    """Whether a neighbour of the floor ``h`` at ``(ix, iy)`` was seen free below ``h``.

    It was when one of its 8 neighbours holds nothing (no floor, no obstacle) and its column
    has a layer observed free (level below 0.5) whose top lies more than ``band`` below
    ``h``: rays passed there under the surface's height, so the surface does not go on into
    that cell. The cell is a raised surface's rim before a drop whose bottom no camera
    position saw — the shadow behind a side edge seen at a grazing angle, wider than
    ``shadow_reach_m`` or never ending in a seen lower floor — where the rim rule finds no
    lower floor. The band spares most of the ground's cells: the layer under the ground's
    (top −0.02 m with the default grid) is cleared by rays to noisy points below the ground,
    though the ground goes on (a ground cell measured above 0 still counts it: the cost in
    the parameter's figures). ``og``, ``floor`` and ``obstacle`` are the stored maps, read
    directly (module note in `_label`).
    """
    nx, ny, nz = og.shape
    # Layers 0 .. below - 1 have their tops below h - band.
    below = min(int(np.ceil((h - band - z_min) / layer)) - 1, nz)
    for jx in range(max(ix - 1, 0), min(ix + 2, nx)):
        for jy in range(max(iy - 1, 0), min(iy + 2, ny)):
            if not np.isnan(floor[jx, jy]) or not np.isnan(obstacle[jx, jy]):
                continue
            for k in range(below):
                if og[jx, jy, k] < LEVEL_UNKNOWN:
                    return True
    return False


@numba.njit(cache=True, inline="always")
def _label(
    top: float,
    hf: float,
    ends: int,
    passes: int,
    delta: float,
    min_rays: int,
    pass_fraction: float,
) -> tuple[np.int8, float]:
    """Eq. 11 with the cover check for one cell: (type, height), before the edge band.

    Scalars in and out: an inlined helper taking the maps costs reference counting per call
    (measured: 18 → 96 µs for a 50 × 50 area). The rules' helpers take the maps: they run
    only for the few floors the gate does not pass, inlined into `_banded_unknown`.
    """
    reached = ends + passes
    covered = not (pass_fraction > 0.0 and reached >= min_rays and passes > pass_fraction * reached)
    if not np.isnan(top) and (np.isnan(hf) or top > hf + delta):
        return _OBSTACLE, top
    if not np.isnan(hf) and covered:
        return _FLOOR, hf
    return _UNKNOWN, np.nan


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, boundscheck=False, error_model="numpy")
def _banded_unknown(
    og: NDArray[np.uint8],
    floor: NDArray[np.float64],
    obstacle: NDArray[np.float64],
    above: NDArray[np.float64],
    below: NDArray[np.float64],
    spill: NDArray[np.float64],
    ix: int,
    iy: int,
    i: int,
    j: int,
    h: float,
    z_min: float,
    layer: float,
    band: float,
    delta: float,
    rise: int,
    shadow: int,
    seen_drop: bool,
    spill_rims: bool,
) -> bool:
    """Whether the banded rules make the floor ``h`` at grid cell ``(ix, iy)`` unknown.

    The rules of `update_fog_area` in its order, the first that fires deciding: the rim and
    beside-obstacle rule (a neighbour's ``above`` below ``h`` or ``below`` above it), the
    narrow rise (``rise`` > 0, `_at_narrow_rise`), the wide shadow (``shadow`` > 1,
    `_behind_wide_shadow`), the seen drop (`_rim_over_seen_drop`) and the spill rule
    (``spill_rims``: a neighbour's ``spill`` below ``h``, `_patch_across`, not across a
    narrow rise). ``above``, ``below`` and ``spill`` are `update_fog_area`'s window arrays,
    ``(i, j)`` the cell's index in them; ``og``, ``floor`` and ``obstacle`` the stored maps.
    One compiled function, called only for the floors the gate does not pass (few: a
    surface's edges), with the rules' helpers inlined into it once.
    """
    wnx, wny = above.shape
    for ki in range(max(i - 1, 0), min(i + 2, wnx)):
        for kj in range(max(j - 1, 0), min(j + 2, wny)):
            if h > above[ki, kj] or h < below[ki, kj]:  # itself: never
                return True
    if rise > 0 and _at_narrow_rise(floor, obstacle, ix, iy, h, band, delta, rise):
        return True
    if shadow > 1 and _behind_wide_shadow(floor, obstacle, ix, iy, h, band, shadow):
        return True
    if seen_drop and _rim_over_seen_drop(og, floor, obstacle, ix, iy, h, z_min, layer, band):
        return True
    if spill_rims:
        for ki in range(max(i - 1, 0), min(i + 2, wnx)):
            for kj in range(max(j - 1, 0), min(j + 2, wny)):
                if (
                    h > spill[ki, kj]  # itself: never (inf)
                    # A riser's edge cell: the upper tread goes on across.
                    and _patch_across(floor, obstacle, ix, iy, i - ki, j - kj, h, band, delta)
                    # A narrow rise (the room's stereo sill, 2–3 cells deep between two
                    # spill cells): the narrow-rise rules judge it.
                    and not _surface_ends_within(
                        floor, obstacle, ix, iy, i - ki, j - kj, _ONE, h, band, rise, _YES
                    )
                ):
                    return True
    return False


@numba.njit(cache=True, inline="always")
def _obstacle_tops(
    og: NDArray[np.uint8],
    obstacle: NDArray[np.float64],
    occ_level: int,
    z_min: float,
    layer: float,
    ix0: int,
    ix1: int,
    iy0: int,
    iy1: int,
) -> None:
    """Eq. 10 in ``[ix0, ix1) × [iy0, iy1)``: ``obstacle`` [m], the highest occupied top.

    NaN where no layer is occupied.
    """
    nz = og.shape[2]
    for ix in range(ix0, ix1):
        for iy in range(iy0, iy1):
            # Highest occupied layer, as a branch-free scan the compiler vectorises.
            k_top = -1
            for k in range(nz):
                k_top = k if og[ix, iy, k] > occ_level else k_top
            obstacle[ix, iy] = z_min + (k_top + 1) * layer if k_top >= 0 else np.nan


@numba.njit(cache=True, inline="always")
def _window_labels(
    floor: NDArray[np.float64],
    obstacle: NDArray[np.float64],
    cover_ends: NDArray[np.int32],
    cover_passes: NDArray[np.int32],
    kinds: NDArray[np.int8],
    heights: NDArray[np.float64],
    wx0: int,
    wx1: int,
    wy0: int,
    wy1: int,
    delta: float,
    min_rays: int,
    pass_fraction: float,
    margin: int,
) -> None:
    """Eq. 11 with the margin and the cover check (`_label`) in a window of the grid.

    Of ``[wx0, wx1) × [wy0, wy1)`` into ``kinds`` and ``heights`` [m] (window indices).
    """
    for ix in range(wx0, wx1):
        for iy in range(wy0, wy1):
            top = obstacle[ix, iy]
            hf = floor[ix, iy]
            if margin > 0 and not np.isnan(hf) and not top > hf + delta:
                beside = _highest_within(obstacle, ix, iy, margin)
                if beside > hf + delta:
                    top = beside
            kinds[ix - wx0, iy - wy0], heights[ix - wx0, iy - wy0] = _label(
                top, hf, cover_ends[ix, iy], cover_passes[ix, iy], delta, min_rays, pass_fraction
            )


@numba.njit(cache=True, inline="always")
def _band_thresholds(
    floor: NDArray[np.float64],
    obstacle: NDArray[np.float64],
    kinds: NDArray[np.int8],
    heights: NDArray[np.float64],
    above: NDArray[np.float64],
    below: NDArray[np.float64],
    spill: NDArray[np.float64],
    lo: NDArray[np.float64],
    hi: NDArray[np.float64],
    bx0: int,
    bx1: int,
    by0: int,
    by1: int,
    wx0: int,
    wy0: int,
    band: float,
    delta: float,
    beside_obstacles: bool,
    spill_rims: bool,
) -> None:
    """The banded rules' thresholds and the gate's bounds [m] per window cell.

    For the cells ``[bx0, bx1) × [by0, by1)`` (grid indices), at window indices (``wx0``,
    ``wy0`` the window's first cell). A floor at h beside a cell is in a band when h >
    ``above`` or h < ``below``: beside a floor more than the band below (a rim), an empty
    cell next to such a floor (a shadow), an obstacle more than δ above that is no higher
    floor's edge (a stored floor within a cell of it lies within δ below its top). It is a
    spill rim candidate when h > ``spill`` (a lower floor under the raised surface's spill).

    The gate (`_fog_rules`): a floor at h none of whose 8 neighbours has h < ``lo`` or
    h > ``hi`` is left a floor by every banded rule, so they need not be evaluated — each
    rule needs such a neighbour: ``lo`` is +inf where no floor is stored (the near rim, the
    shadows and the seen drop all start at such a cell), else the highest of ``below`` and
    the stored floor less the band, with 1e-9 m to spare so that rounding cannot let the
    narrow rise's foot (a neighbour's floor > h + band) pass; ``hi`` is the lowest of
    ``above`` and ``spill``. Only the banded range is written: the labelled cells'
    neighbours lie within it.
    """
    nx, ny = floor.shape
    for ix in range(bx0, bx1):
        for iy in range(by0, by1):
            i, j = ix - wx0, iy - wy0
            kind, h = kinds[i, j], heights[i, j]
            hf = floor[ix, iy]
            rim, lower, spilled = np.inf, -np.inf, np.inf
            if kind == _FLOOR:
                if band > 0.0:
                    rim = h + band
            elif kind == _OBSTACLE:
                if spill_rims and not np.isnan(hf):
                    # A lower floor under this surface's spill: a floor h beside it is a
                    # rim when h > hf + band and the top reaches no higher than h + δ.
                    spilled = max(hf + band, h - delta)
                if beside_obstacles:
                    step = False
                    for jx in range(max(ix - 1, 0), min(ix + 2, nx)):
                        for jy in range(max(iy - 1, 0), min(iy + 2, ny)):
                            step = step or h <= floor[jx, jy] + delta  # NaN: never
                    if not step:
                        lower = h - delta
            elif band > 0.0 and np.isnan(hf) and np.isnan(obstacle[ix, iy]):
                lowest = np.inf
                for ki in range(max(i - 1, 0), min(i + 2, kinds.shape[0])):
                    for kj in range(max(j - 1, 0), min(j + 2, kinds.shape[1])):
                        if kinds[ki, kj] == _FLOOR and heights[ki, kj] < lowest:
                            lowest = heights[ki, kj]
                rim = lowest + band
            above[i, j], below[i, j], spill[i, j] = rim, lower, spilled
            lo[i, j] = np.inf if np.isnan(hf) else max(lower, hf - band + 1e-9)
            hi[i, j] = min(rim, spilled)


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, boundscheck=False, error_model="numpy")
def _fog_prepare(
    og: NDArray[np.uint8],
    floor: NDArray[np.float64],
    obstacle: NDArray[np.float64],
    cover_ends: NDArray[np.int32],
    cover_passes: NDArray[np.int32],
    kinds: NDArray[np.int8],
    window: NDArray[np.float64],
    occ_level: int,
    z_min: float,
    layer: float,
    delta: float,
    ix0: int,
    ix1: int,
    iy0: int,
    iy1: int,
    wx0: int,
    wx1: int,
    wy0: int,
    wy1: int,
    banded_ring: int,
    min_rays: int,
    pass_fraction: float,
    margin: int,
    band: float,
    beside_obstacles: bool,
    spill_rims: bool,
    banded: bool,
) -> None:
    """`update_fog_area`'s first kernel: eq. 10 in the area, eq. 11 in the window, thresholds.

    ``obstacle`` in ``[ix0, ix1) × [iy0, iy1)`` (`_obstacle_tops`); ``kinds``, ``heights``
    of the window ``[wx0, wx1) × [wy0, wy1)`` (`_window_labels`); with ``banded`` the
    thresholds and gate bounds of the area grown by ``banded_ring`` cells
    (`_band_thresholds`, clipped to the grid). The
    window arrays are indexed from the window's first cell: ``kinds`` and ``window``, the
    (6, wnx, wny) stack of ``heights``, ``above``, ``below``, ``spill``, ``lo`` and ``hi``
    [m] (one allocation, one argument: `update_fog_area` is a Python function calling two
    kernels, so that each is compiled and optimised once — numba links a kernel's callees
    into it and optimises them again —, and each array argument costs it a little).
    """
    heights, above, below, spill, lo, hi = window
    _obstacle_tops(og, obstacle, occ_level, z_min, layer, ix0, ix1, iy0, iy1)
    _window_labels(
        floor,
        obstacle,
        cover_ends,
        cover_passes,
        kinds,
        heights,
        wx0,
        wx1,
        wy0,
        wy1,
        delta,
        min_rays,
        pass_fraction,
        margin,
    )
    if banded:
        nx, ny = floor.shape
        _band_thresholds(
            floor,
            obstacle,
            kinds,
            heights,
            above,
            below,
            spill,
            lo,
            hi,
            max(ix0 - banded_ring, 0),
            min(ix1 + banded_ring, nx),
            max(iy0 - banded_ring, 0),
            min(iy1 + banded_ring, ny),
            wx0,
            wy0,
            band,
            delta,
            beside_obstacles,
            spill_rims,
        )


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, boundscheck=False, error_model="numpy")
def _fog_rules(
    og: NDArray[np.uint8],
    floor: NDArray[np.float64],
    obstacle: NDArray[np.float64],
    kinds: NDArray[np.int8],
    window: NDArray[np.float64],
    out_types: NDArray[np.int8],
    out_heights: NDArray[np.float64],
    ox: int,
    oy: int,
    ix0: int,
    ix1: int,
    iy0: int,
    iy1: int,
    labelled_ring: int,
    wx0: int,
    wy0: int,
    z_min: float,
    layer: float,
    band: float,
    delta: float,
    rise: int,
    shadow: int,
    seen_drop: bool,
    spill_rims: bool,
    banded: bool,
    ground_noise: bool,
) -> None:
    """`update_fog_area`'s second kernel: the banded labels of the area and its ring.

    The cells are ``[ix0, ix1) × [iy0, iy1)`` grown by ``labelled_ring`` cells (clipped).

    Each cell's eq. 11 label (``kinds``, ``heights``: window arrays from ``(wx0, wy0)``),
    with ``banded`` made unknown where a floor is not calm (the gate, `_band_thresholds`:
    most floors are, away from edges) and `_banded_unknown` says so, goes to ``out_types``,
    ``out_heights`` at the grid cell less ``(ox, oy)``: the FOG itself (0, 0), or the
    window's labels for the island rule (``(wx0, wy0)``). ``window`` as in `_fog_prepare`.
    """
    heights, above, below, spill, lo, hi = window
    nx, ny = floor.shape
    for ix in range(max(ix0 - labelled_ring, 0), min(ix1 + labelled_ring, nx)):
        for iy in range(max(iy0 - labelled_ring, 0), min(iy1 + labelled_ring, ny)):
            i, j = ix - wx0, iy - wy0
            kind, h = kinds[i, j], heights[i, j]
            calm = True
            if banded and kind == _FLOOR:
                for ki in range(max(i - 1, 0), min(i + 2, kinds.shape[0])):
                    for kj in range(max(j - 1, 0), min(j + 2, kinds.shape[1])):
                        calm = calm and lo[ki, kj] <= h <= hi[ki, kj]
            if (
                banded
                and kind == _FLOOR
                and not calm
                and _banded_unknown(
                    og,
                    floor,
                    obstacle,
                    above,
                    below,
                    spill,
                    ix,
                    iy,
                    i,
                    j,
                    h,
                    z_min,
                    layer,
                    band,
                    delta,
                    rise,
                    shadow,
                    seen_drop,
                    spill_rims,
                )
            ):
                kind, h = _UNKNOWN, np.nan
            if (
                ground_noise
                and kind == _OBSTACLE
                and _ground_noise(floor, obstacle, ix, iy, h, delta)
            ):
                kind, h = _UNKNOWN, np.nan
            out_types[ix - ox, iy - oy] = kind
            out_heights[ix - ox, iy - oy] = h


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, boundscheck=False, error_model="numpy")
def _fog_islands(
    floor: NDArray[np.float64],
    obstacle: NDArray[np.float64],
    labels: NDArray[np.int8],
    label_heights: NDArray[np.float64],
    fog_types: NDArray[np.int8],
    fog_heights: NDArray[np.float64],
    gx0: int,
    gx1: int,
    gy0: int,
    gy1: int,
    wx0: int,
    wy0: int,
    band: float,
    island: int,
    delta: float,
    ground_noise: bool,
) -> None:
    """`update_fog_area`'s island rule (``min_floor_neighbours`` k > 0) into the FOG.

    For ``[gx0, gx1) × [gy0, gy1)``: a floor among the banded ``labels`` (window arrays
    from ``(wx0, wy0)``) with fewer than ``island`` of its 8 neighbours floors within
    ``band`` of it and one of them an obstacle higher than it is unknown.
    """
    for ix in range(gx0, gx1):
        for iy in range(gy0, gy1):
            i, j = ix - wx0, iy - wy0
            kind, h = labels[i, j], label_heights[i, j]
            if kind == _FLOOR:
                level = 0
                taller = False
                for ki in range(max(i - 1, 0), min(i + 2, labels.shape[0])):
                    for kj in range(max(j - 1, 0), min(j + 2, labels.shape[1])):
                        if ki == i and kj == j:
                            continue
                        near, hn = labels[ki, kj], label_heights[ki, kj]
                        if near == _FLOOR and abs(hn - h) <= band:
                            level += 1
                        taller = taller or (near == _OBSTACLE and hn > h)
                if level < island and taller:
                    kind, h = _UNKNOWN, np.nan
            if (
                ground_noise
                and kind == _OBSTACLE
                and _ground_noise(floor, obstacle, ix, iy, h, delta)
            ):
                kind, h = _UNKNOWN, np.nan
            fog_types[ix, iy] = kind
            fog_heights[ix, iy] = h


def update_fog_area(
    og: NDArray[np.uint8],
    floor: NDArray[np.float64],
    obstacle: NDArray[np.float64],
    fog_types: NDArray[np.int8],
    fog_heights: NDArray[np.float64],
    occ_level: int,
    z_min: float,
    layer: float,
    delta: float,
    ix0: int,
    ix1: int,
    iy0: int,
    iy1: int,
    cover_ends: NDArray[np.int32],
    cover_passes: NDArray[np.int32],
    min_rays: int,
    pass_fraction: float,
    margin: int = 0,
    band: float = 0.0,
    beside_obstacles: bool = False,
    rise_cells: int = 0,
    shadow_cells: int = 0,
    min_floor_neighbours: int = 0,
    rim_over_spill: bool = False,
    seen_drop: bool = False,
    ground_noise: bool = False,
) -> None:
    """Recompute ``obstacle`` (eq. 10) and the FOG (eq. 11) in ``[ix0, ix1) × [iy0, iy1)``.

    A floor reached by at least ``min_rays`` rays of which more than ``pass_fraction`` passed
    through it (`mapper.floor_cover`) does not cover its cell: the cell is then unknown unless
    eq. 11 makes it an obstacle; ``pass_fraction`` 0 = off (the paper).

    With ``margin`` m > 0 (`MapperParams.obstacle_margin_cells`) eq. 11 takes ``h_o`` as the
    highest top within m cells (module docstring), so the FOG is recomputed m cells beyond
    the area too (clipped to the grid): their windows reach into it. ``obstacle`` outside the
    area is current, as only the area's columns changed.

    With ``band`` > 0 (`MapperParams.edge_band_m`) a floor is unknown beside a floor more than
    ``band`` below it, with ``beside_obstacles`` (`MapperParams.unknown_beside_obstacles`)
    beside an obstacle more than δ above it that is no higher floor's edge (module docstring).
    The neighbours' labels are recomputed from the maps (never read from ``fog_types``, which
    holds banded labels), so the result does not depend on the order of the cells; the FOG is
    recomputed ``m + 2`` cells beyond the area (whether a neighbour is a higher floor's edge,
    or a shadow, depends on the maps within a cell of it).

    With ``band`` > 0 and ``rise_cells`` n > 0 (`MapperParams.narrow_rise_m`) a floor is
    unknown at the foot of a narrow raised surface too (`_at_narrow_rise`): the FOG is then
    recomputed at least ``n + 1`` cells beyond the area, as far as that test reads ``floor``.

    With ``band`` > 0 and ``shadow_cells`` s > 1 (`MapperParams.shadow_reach_m`) a floor is
    unknown beside a shadow up to s cells wide too (`_behind_wide_shadow`): the FOG is then
    recomputed at least ``s + 1`` cells beyond the area.

    With ``band`` > 0 and ``rim_over_spill`` (`MapperParams.rim_over_spill`) a floor at ``h``
    is unknown beside an obstacle too whose stored floor lies more than ``band`` below ``h``
    and whose top reaches no higher than ``h`` + δ (a lower floor under the raised surface's
    spill), when the raised floor ends across from it (`_patch_across`; not a tread's first
    row); its reach is the rim rule's and the cell across, within the ring.

    With ``band`` > 0 and ``seen_drop`` (`MapperParams.rim_over_seen_drop`) a floor is
    unknown beside a cell holding nothing whose column was observed free below the floor's
    height (`_rim_over_seen_drop`); its reach is the rim rule's.

    With ``ground_noise`` (`MapperParams.ground_noise_unknown`) an obstacle of eq. 11 whose top
    lies within δ above the lowest of at least 3 neighbouring floors eq. 11 leaves floors is
    written unknown (`_ground_noise`), after every other rule.

    With ``band`` > 0 and ``min_floor_neighbours`` k > 0 (`MapperParams.min_floor_neighbours`)
    a floor that the rules above leave a floor is unknown when fewer than k of its 8
    neighbours are left floors within ``band`` of its height and one of them is an obstacle
    higher than it: a patch of floor too small to stand on, inside something taller (a plane
    fitted to a rough top's low part). The neighbours' labels are the rules' (computed here
    a cell farther), so the FOG is recomputed a cell farther too.
    """
    nx, ny = floor.shape
    # Python ints: numpy scalars' arithmetic costs this Python function more than its work.
    ix0, ix1, iy0, iy1 = int(ix0), int(ix1), int(iy0), int(iy1)
    # The cells recomputed, and around them (with the band) their neighbours' labels.
    banded = band > 0.0 or beside_obstacles
    ring = margin + (2 if banded else 0)
    rise = rise_cells if band > 0.0 else 0
    if rise > 0:
        ring = max(ring, rise + 1)
    shadow = shadow_cells if band > 0.0 else 0
    if shadow > 1:
        ring = max(ring, shadow + 1)
    island = min_floor_neighbours if band > 0.0 else 0
    if island > 0:
        ring += 1  # a label reads its neighbours' banded labels
    # The banded labels are computed ``extra`` cells beyond the cells written.
    extra = 1 if island > 0 else 0
    reach = ring + 2 + extra if banded else ring
    wx0, wx1 = max(ix0 - reach, 0), min(ix1 + reach, nx)
    wy0, wy1 = max(iy0 - reach, 0), min(iy1 + reach, ny)
    shape = (wx1 - wx0, wy1 - wy0)
    kinds = np.empty(shape, dtype=np.int8)
    # heights, above, below, spill, lo, hi: one allocation (module note in `_fog_prepare`).
    window = np.empty((6, *shape))
    spill_rims = rim_over_spill and band > 0.0
    _fog_prepare(
        og,
        floor,
        obstacle,
        cover_ends,
        cover_passes,
        kinds,
        window,
        occ_level,
        z_min,
        layer,
        delta,
        ix0,
        ix1,
        iy0,
        iy1,
        wx0,
        wx1,
        wy0,
        wy1,
        ring + 1 + extra,
        min_rays,
        pass_fraction,
        margin,
        band,
        beside_obstacles,
        spill_rims,
        banded,
    )
    # Without the island rule the labels go to the FOG, else to the window for that rule.
    labels, label_heights, ox, oy = fog_types, fog_heights, 0, 0
    if island > 0:
        labels, label_heights, ox, oy = np.empty_like(kinds), np.empty(shape), wx0, wy0
    _fog_rules(
        og,
        floor,
        obstacle,
        kinds,
        window,
        labels,
        label_heights,
        ox,
        oy,
        ix0,
        ix1,
        iy0,
        iy1,
        ring + extra,
        wx0,
        wy0,
        z_min,
        layer,
        band,
        delta,
        rise,
        shadow,
        seen_drop,
        spill_rims,
        banded,
        ground_noise and island == 0,  # with the island rule: after it (`_fog_islands`)
    )
    if island > 0:
        _fog_islands(
            floor,
            obstacle,
            labels,
            label_heights,
            fog_types,
            fog_heights,
            max(ix0 - ring, 0),
            min(ix1 + ring, nx),
            max(iy0 - ring, 0),
            min(iy1 + ring, ny),
            wx0,
            wy0,
            band,
            island,
            delta,
            ground_noise,
        )


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def ceiling_map(
    og: NDArray[np.uint8],
    floor: NDArray[np.float64],
    occ_level: int,
    z_min: float,
    layer: float,
    delta: float,
) -> NDArray[np.float64]:
    """(nx, ny) ceiling heights [m] as defined in the module docstring, NaN where none."""
    nx, ny, nz = og.shape
    out = np.empty((nx, ny))  # not np.full: its overload would be compiled for this alone
    for ix in range(nx):
        for iy in range(ny):
            out[ix, iy] = np.nan
            hf = floor[ix, iy]
            seen_free = False
            for k in range(nz):
                level = og[ix, iy, k]
                if level > occ_level:
                    if np.isnan(hf):
                        if seen_free:
                            out[ix, iy] = z_min + k * layer
                            break
                    elif z_min + (k + 1) * layer > hf + delta:
                        out[ix, iy] = z_min + k * layer
                        break
                elif level < LEVEL_UNKNOWN:
                    seen_free = True
    return out


# ---------------------------------------------------------------------------------------------
# Unconfirmed floors (`MapperParams.min_floor_frames`), after every other rule.


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, boundscheck=False, error_model="numpy")
def mark_unconfirmed_floors(
    floor: NDArray[np.float64],
    obstacle: NDArray[np.float64],
    frame_votes: NDArray[np.int32],
    fog_types: NDArray[np.int8],
    fog_heights: NDArray[np.float64],
    min_frames: int,
    band: float,
    eps: float,
    ix0: int,
    ix1: int,
    iy0: int,
    iy1: int,
) -> int:
    """Beyond the paper: a floor only one frame has seen as a plane, inside something, is unknown.

    In ``[ix0, ix1) × [iy0, iy1)`` (clipped to the grid) a cell the FOG labels floor whose
    stored floor ``h`` holds fewer than ``min_frames`` frame votes (`MapperParams.floor_frame_cap`:
    the frames that saw it as a plane, less those that saw no plane at its height) is unknown
    when none of its 8 neighbours holds a floor within ``band`` of ``h`` with ``min_frames``
    votes or more, and two opposite neighbours (north and south, east and west, or across a
    diagonal) hold no floor and an obstacle top (eq. 10) no lower than ``h − eps``: the floor
    lies inside something reaching its level (a rough top's columns around its level patch,
    whether their bumps rise above it or not), not at its edge (a tread at its riser, the
    ground at a wall, have such a neighbour on one side only). Now and then depth
    noise lets a level patch of a rough top pass the segmentation's floor tests (stage, depth
    seed 3: 25 regions in 832 frames, `SegmentationParams.floor_max_noise_ratio`), each time
    elsewhere on the top and at another height, so another frame rarely confirms it; the
    frames that see the top rough take it away (`mapper.floor_map.frame_verdicts`), but the
    last frames' patches stay. A real surface is seen as a plane frame after frame, and a
    floor seen for the first time beside a confirmed one of its height (a surface growing at
    the edge of the view) keeps its label. Output only: the maps, and what the other rules
    see, are unchanged.

    The rule reads the maps, not the labels, so the result does not depend on the order of the
    cells. The caller passes exactly the window whose labels `update_fog_area` (and
    `mark_raised_rims`) have just written, for a stale area grown by a cell
    (`FloorObstacleMapper.update`): a cell whose neighbour's maps changed is rewritten and
    judged again.

    Returns:
        How many cells were relabelled.
    """
    nx, ny = floor.shape
    changed = 0
    for ix in range(max(ix0, 0), min(ix1, nx)):
        for iy in range(max(iy0, 0), min(iy1, ny)):
            if fog_types[ix, iy] != _FLOOR or frame_votes[ix, iy] >= min_frames:
                continue
            h = floor[ix, iy]
            if np.isnan(h):
                continue
            confirmed = False
            for jx in range(max(ix - 1, 0), min(ix + 2, nx)):
                for jy in range(max(iy - 1, 0), min(iy + 2, ny)):
                    f = floor[jx, jy]
                    if (jx != ix or jy != iy) and frame_votes[jx, jy] >= min_frames:
                        confirmed = confirmed or abs(f - h) <= band  # NaN floor: False
            # Opposite neighbours (N-S, E-W and the diagonals) both of something reaching h.
            inside = False
            for dx, dy in ((1, 0), (0, 1), (1, 1), (1, -1)):
                ax, ay, bx, by = ix + dx, iy + dy, ix - dx, iy - dy
                if 0 <= ax < nx and 0 <= ay < ny and 0 <= bx < nx and 0 <= by < ny:
                    inside = inside or (
                        np.isnan(floor[ax, ay])
                        and obstacle[ax, ay] >= h - eps  # NaN top: nothing
                        and np.isnan(floor[bx, by])
                        and obstacle[bx, by] >= h - eps
                    )
            if inside and not confirmed:
                fog_types[ix, iy] = _UNKNOWN
                fog_heights[ix, iy] = np.nan
                changed += 1
    return changed


# ---------------------------------------------------------------------------------------------
# Raised rims (`MapperParams.raised_rim_obstacle`), kept apart from `update_fog_area`'s rules.


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, boundscheck=False, error_model="numpy")
def mark_raised_rims(
    floor: NDArray[np.float64],
    obstacle: NDArray[np.float64],
    fog_types: NDArray[np.int8],
    fog_heights: NDArray[np.float64],
    delta: float,
    ix0: int,
    ix1: int,
    iy0: int,
    iy1: int,
) -> int:
    """Beyond the paper: the rim of a floor raised more than δ above its neighbour is an obstacle.

    In ``[ix0, ix1) × [iy0, iy1)`` (clipped to the grid), a cell the FOG labels floor at ``h``
    becomes an obstacle when one of its 8 neighbours holds a stored floor more than δ below
    ``h`` whose column reaches no higher than ``h + δ`` (eq. 10: the rise's foot or its edge
    cell, whatever its label — eq. 11, the margin or the band may have made it anything —
    and not something taller, which eq. 11 judges). Its height is its own column's top (eq.
    10; ``h`` if none). The camera pose's error (moving_box, a standing robot that sees
    nothing static but the ground: 1–3 cm at the box, which nothing in the scene can correct)
    puts the map's edge a cell either way of the true one, so the rim cell may hold the
    riser; with `MapperParams.obstacle_margin_cells` ≥ 1 the cell at the rise's foot is an
    obstacle too, and the two cover the true edge cell on either side. A rise of at most δ
    (a sill, a tread) keeps its rim: eq. 11 calls such a rise floor on both sides.

    The rule reads the maps, not the neighbours' labels, so the result does not depend on the
    order of the cells. The caller passes exactly the window whose labels `update_fog_area`
    has just written, for an area grown by a cell (`FloorObstacleMapper.update`): a cell
    relabelled by an earlier frame is then either rewritten and judged again, or outside it,
    where no neighbour's maps changed.

    Returns:
        How many cells were relabelled.
    """
    nx, ny = floor.shape
    changed = 0
    for ix in range(max(ix0, 0), min(ix1, nx)):
        for iy in range(max(iy0, 0), min(iy1, ny)):
            if fog_types[ix, iy] != _FLOOR:
                continue
            h = fog_heights[ix, iy]
            rim = False
            for jx in range(max(ix - 1, 0), min(ix + 2, nx)):
                for jy in range(max(iy - 1, 0), min(iy + 2, ny)):
                    # NaN floor: no foot; NaN top (nothing occupied): nothing taller.
                    rim = rim or (floor[jx, jy] < h - delta and not obstacle[jx, jy] > h + delta)
            if rim:
                own_top = obstacle[ix, iy]
                fog_types[ix, iy] = _OBSTACLE
                fog_heights[ix, iy] = h if np.isnan(own_top) else own_top
                changed += 1
    return changed
