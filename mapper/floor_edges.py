"""Cells an edge may run through: split columns, weak feet, uncovered rims (beyond the paper).

A 4 cm cell over a riser holds part of each tread. The floor map keeps one height per cell
(eq. 9 with votes: the surface most of its points come from), so the FOG calls such a cell a
floor at one tread's height, and a foot put on it stands partly on the other tread. The truth
(DESIGN.md "Ground truth") calls it an obstacle: a riser's face lies in it. On the shipped
stage every edge lies on a cell boundary and no cell holds one; on `stage_offgrid` (the same
stage 20 mm and 13 mm off the lattice) the FOG labels such cells floor in depth mode too.

A frame that sees both treads in such a column gives it floor points of two planes whose
heights differ by the riser. This module counts, per column, the frames that gave it two
floor points or more (``multi``) and those whose floor points' plane heights spread more than
a gap (``split``), apart by where the stored floor lies: above the split's lower plane (the
column holds the higher surface and the lower one shows in it: ``split_frames``) or at it
(``lower_split_frames``). The FOG leaves a floor unknown where a share of the multi frames is
split (`MapperParams.edge_split_share`, `edge_split_lower_share`) and the column stands out
across the edge (`MapperParams.edge_split_contrast`): `mark_floor_edges`.

A share alone cannot tell a riser on the column's boundary from one inside it. Pose error and
the segmentation carry a plane's points 1–2 cm across an edge, so the column on either side of a
riser that lies on a boundary is split too: on the shipped stage (depth, seed 1) the lower
treads' last columns in 31–49 % of their multi frames, the room's sill's first column in about
30 %, against 26–70 % for the columns a riser runs through on `stage_offgrid`. What tells them
apart is the neighbours: a riser on a boundary splits the columns on both
its sides about as often (86 and 110 frames beside the stage's step_3 riser, seed 1), a riser
inside a column splits it far more often than either neighbour across the edge (160 against 13
and 32 on `stage_offgrid`), as each frame's pose error moves the edge by a centimetre or two.

Both counts are halved when ``multi`` reaches `SPLIT_FRAME_CAP`, so they are bounded and a
scene that changed (a box taken away) is followed within some tens of frames. The counting
costs 0.02–0.03 ms of the stage's 0.8 ms update, the split rule's FOG part 0.04 ms with the FOG
read after every frame (depth seed 1, 400 frames, on and off interleaved, medians, AMD EPYC,
load 1.5–4; computed with numpy instead it took 0.17 ms), the two rules below 0.06 ms more
(`stage_offgrid` depth seed 1, the same way, load 1–5); all three are one pass,
`mark_floor_edges`.

A side edge splits no column: the ground beside a raised surface's side lies behind that side
from every place on or in front of the surface, so no frame sees both. There the cell the
edge runs through takes either surface, and the camera pose's error (odometry drifts 2–3 cm
sideways over the stage, which no correction takes out) puts the raised surface's points a
cell either way. On `stage_offgrid` (depth, seed 1) the platform's cells at y = 0 … 0.04 m
(2.7 cm of platform, 1.3 cm of ground) held the ground's height, from 1–4 frames that saw the
ground there from afar, against 40 for every cell around them: the rim rule
(`MapperParams.edge_band_m`) left them floors, as the lower side of a raised floor, and made
the platform's next column unknown. `mark_floor_edges` makes a floor unknown when fewer than
`MapperParams.edge_foot_min_frames` frames confirmed it and a neighbour holds a floor more
than the band above: the lower side of an edge is kept only where the frames saw it
(a tread before a riser the robot walks up to is confirmed by tens of frames).

The same drift carries a raised surface's map a cell past its side edge. Where the rays reach
that cell at the surface's height and go on below it (the cover check, `mapper.floor_cover`:
the cell is then unknown), the edge lies in it or, drift taken into account, in the floor
beside it: `mark_floor_edges` makes that floor unknown too, when the uncovered cell is the
surface's last, no frame split it (a riser seen with both its treads is judged by the split
rule) and the surface goes on behind the floor (a narrow rise's rims are the narrow-rise
rule's). On `stage_offgrid` (depth, seed 3) the platform's map reached 4 cm past its side at
y = 0.013 m; the cell holding the edge (2.7 cm of platform) was a floor at the platform's
height, with 600 rays ending on it and 1 passing, the cell beyond 55 % passed.
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

from mapper.grid import CellType

#: ``multi`` at which both counts of a column are halved: 64 frames, 5 s at 12.5 frames/s,
#: so an edge that went away (a box removed) loses its share within a few seconds of being
#: seen, while a riser the robot watches while walking up to it keeps a share measured over
#: many frames.
SPLIT_FRAME_CAP = 64
#: Fewest split frames a column needs before its share counts: one frame's stray point of
#: another plane (a tread's points a centimetre past its edge) never makes an edge.
SPLIT_MIN_FRAMES = 2

_FLOOR = np.int8(CellType.FLOOR)
_UNKNOWN = np.int8(CellType.UNKNOWN)


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, boundscheck=False, error_model="numpy")
def count_split_frames(
    split_frames: NDArray[np.int32],
    lower_split_frames: NDArray[np.int32],
    multi_frames: NDArray[np.int32],
    low: NDArray[np.float64],
    high: NDArray[np.float64],
    count: NDArray[np.int32],
    floor: NDArray[np.float64],
    point_cell: NDArray[np.int64],
    floor_heights: NDArray[np.float64],
    gap: float,
) -> int:
    """Count one frame in the split and multi frames of every column it sees (module doc).

    Args:
        split_frames: (nx*ny,) frames whose floor points in the column spread over more than
            ``gap`` in plane height under a stored floor more than ``gap`` above their lowest
            plane; updated in place.
        lower_split_frames: (nx*ny,) the other split frames: the stored floor at (or within
            ``gap`` of) the lowest plane, or none; updated in place.
        multi_frames: (nx*ny,) frames that gave the column two floor points or more; updated
            in place.
        low: (nx*ny,) scratch, all ``inf`` on entry and on return.
        high: (nx*ny,) scratch, all ``-inf`` on entry and on return.
        count: (nx*ny,) scratch, all zero on entry and on return.
        floor: (nx*ny,) stored floor heights [m] (NaN = none): a split counts only under a
            floor stored above its lower plane.
        point_cell: (N,) column index ``ix*ny + iy`` of each point, negative if dropped.
        floor_heights: (N,) height of each point's plane [m]; non-finite = not floor.
        gap: Spread of plane heights [m] above which a column is split in this frame.

    Returns:
        How many columns were split in this frame.
    """
    for i in range(point_cell.shape[0]):
        col = point_cell[i]
        h = floor_heights[i]
        if col < 0 or not np.isfinite(h):
            continue
        count[col] += 1
        low[col] = min(low[col], h)
        high[col] = max(high[col], h)
    split = 0
    # Once per column the frame gave floor points (``count`` zeroed once counted).
    for i in range(point_cell.shape[0]):
        col = point_cell[i]
        if col < 0 or count[col] == 0:
            continue
        if count[col] >= 2:
            multi_frames[col] += 1
            if high[col] - low[col] > gap:
                if floor[col] - low[col] > gap:
                    split_frames[col] += 1
                else:
                    lower_split_frames[col] += 1
                split += 1
            if multi_frames[col] >= SPLIT_FRAME_CAP:
                multi_frames[col] //= 2
                split_frames[col] //= 2
                lower_split_frames[col] //= 2
        count[col] = 0
        low[col] = np.inf
        high[col] = -np.inf
    return split


@numba.njit(cache=True, inline="always")
def _split_total(split_frames, lower_split_frames, ix: int, iy: int) -> float:
    """Both kinds of split frames of column ``(ix, iy)``; 0 beyond the grid."""
    nx, ny = split_frames.shape
    if ix < 0 or iy < 0 or ix >= nx or iy >= ny:
        return 0.0
    return float(split_frames[ix, iy] + lower_split_frames[ix, iy])


@numba.njit(cache=True, inline="always")
def _split_edge(
    split_frames, lower_split_frames, multi_frames, ix: int, iy: int, share, lower_share, contrast
) -> bool:
    """The split rule at column ``(ix, iy)`` (`mark_floor_edges`)."""
    multi = float(multi_frames[ix, iy])
    split = split_frames[ix, iy]
    lower = lower_split_frames[ix, iy]
    edge = (share > 0.0 and split >= SPLIT_MIN_FRAMES and split >= share * multi) or (
        lower_share > 0.0 and lower >= SPLIT_MIN_FRAMES and lower >= lower_share * multi
    )
    if not edge or contrast <= 0.0:
        return edge
    level = float(split + lower) / contrast
    for dx, dy in ((1, 0), (0, 1), (1, 1), (1, -1)):
        ahead = _split_total(split_frames, lower_split_frames, ix + dx, iy + dy)
        behind = _split_total(split_frames, lower_split_frames, ix - dx, iy - dy)
        if ahead <= level and behind <= level:
            return True
    return False


@numba.njit(cache=True, inline="always")
def _weak_foot(floor, frame_votes, ix: int, iy: int, h: float, min_frames, band) -> bool:
    """The weak-foot rule for the floor ``h`` at column ``(ix, iy)`` (`mark_floor_edges`)."""
    if frame_votes[ix, iy] >= min_frames:
        return False
    nx, ny = floor.shape
    for jx in range(max(ix - 1, 0), min(ix + 2, nx)):
        for jy in range(max(iy - 1, 0), min(iy + 2, ny)):
            if floor[jx, jy] > h + band:  # NaN: never
                return True
    return False


@numba.njit(cache=True, inline="always")
def _same_floor(floor, ix: int, iy: int, h: float, eps: float) -> bool:
    """Whether column ``(ix, iy)`` lies in the grid and stores a floor within ``eps`` of ``h``."""
    nx, ny = floor.shape
    if ix < 0 or iy < 0 or ix >= nx or iy >= ny:
        return False
    return abs(floor[ix, iy] - h) <= eps  # NaN: never


@numba.njit(cache=True, inline="always")
def _uncovered_rim(
    floor,
    cover_ends,
    cover_passes,
    split_frames,
    lower_split_frames,
    ix: int,
    iy: int,
    h: float,
    min_rays,
    pass_fraction,
    eps,
    inward,
) -> bool:
    """The uncovered-rim rule for the floor ``h`` at column ``(ix, iy)`` (`mark_floor_edges`)."""
    for dx, dy in ((1, 0), (-1, 0), (0, 1), (0, -1)):
        jx, jy = ix + dx, iy + dy
        if not _same_floor(floor, jx, jy, h, eps):
            continue
        reached = cover_ends[jx, jy] + cover_passes[jx, jy]
        uncovered = reached >= min_rays and cover_passes[jx, jy] > pass_fraction * reached
        unsplit = split_frames[jx, jy] + lower_split_frames[jx, jy] < SPLIT_MIN_FRAMES
        if not uncovered or not unsplit or _same_floor(floor, jx + dx, jy + dy, h, eps):
            continue
        goes_on = True
        for k in range(1, inward + 1):
            goes_on = goes_on and _same_floor(floor, ix - k * dx, iy - k * dy, h, eps)
        if goes_on:
            return True
    return False


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, boundscheck=False, error_model="numpy")
def mark_floor_edges(
    fog_types: NDArray[np.int8],
    fog_heights: NDArray[np.float64],
    floor: NDArray[np.float64],
    frame_votes: NDArray[np.int32],
    split_frames: NDArray[np.int32],
    lower_split_frames: NDArray[np.int32],
    multi_frames: NDArray[np.int32],
    cover_ends: NDArray[np.int32],
    cover_passes: NDArray[np.int32],
    share: float,
    lower_share: float,
    contrast: float,
    min_frames: int,
    band: float,
    rims: bool,
    min_rays: int,
    pass_fraction: float,
    eps: float,
    inward: int,
    ix0: int,
    ix1: int,
    iy0: int,
    iy1: int,
) -> int:
    """Make unknown the floors in ``[ix0, ix1) × [iy0, iy1)`` an edge may run through.

    Three rules (module note), a floor unknown where one holds; each reads the stored maps and
    counts, not the labels, so the result does not depend on the order of the cells:

    - split: its column was split in at least ``share`` of its multi frames under a stored
      floor above the lower plane, or ``lower_share`` at it (each at least `SPLIT_MIN_FRAMES`
      times; a share of 0 leaves its kind out), and, with ``contrast > 0``, its split frames
      of both kinds are at least ``contrast`` times those of both its neighbours along x, y or
      a diagonal (beyond the grid: never split);
    - weak foot (``min_frames`` > 0): fewer than ``min_frames`` frames confirmed it and one of
      its 8 neighbours stores a floor more than ``band`` above it;
    - uncovered rim (``rims``): along x or y its neighbour stores its surface's last floor
      (within ``eps`` of it, the cell beyond not), which the cover check finds uncovered (at
      least ``min_rays`` rays reached it, more than ``pass_fraction`` passed:
      `mapper.floor_cover`), in a column split fewer than `SPLIT_MIN_FRAMES` times, and the
      surface goes on for ``inward`` cells the other way.

    Args:
        fog_types: (nx, ny) FOG labels; floors an edge may run through become unknown in place.
        fog_heights: (nx, ny) FOG heights [m]; NaN where a floor became unknown.
        floor: (nx, ny) stored floor heights [m] (eq. 9), NaN = none.
        frame_votes: (nx, ny) the stored floors' frame votes (`mapper.floor_map`).
        split_frames: (nx, ny) split frames under a floor above the lower plane.
        lower_split_frames: (nx, ny) the other split frames.
        multi_frames: (nx, ny) frames with two floor points or more.
        cover_ends: (nx, ny) rays that ended on each stored floor (`mapper.floor_cover`).
        cover_passes: (nx, ny) rays that passed through it.
        share: `MapperParams.edge_split_share`.
        lower_share: `MapperParams.edge_split_lower_share`.
        contrast: `MapperParams.edge_split_contrast`; 0 = the shares alone.
        min_frames: `MapperParams.edge_foot_min_frames`; 0 = off.
        band: The rise [m] that makes a neighbour a raised floor: `MapperParams.edge_band_m`.
        rims: `MapperParams.uncovered_rims`.
        min_rays: `MapperParams.floor_pass_min_rays`.
        pass_fraction: `MapperParams.floor_pass_fraction`.
        eps: `MapperParams.eps_m`: the same surface [m].
        inward: Cells the surface must go on beyond a rim, away from its uncovered neighbour:
            `MapperParams.narrow_rise_cells`.
        ix0: First column along x of the window.
        ix1: One past the last, clipped to the grid.
        iy0: First column along y.
        iy1: One past the last, clipped to the grid.

    Returns:
        How many floors became unknown.
    """
    nx, ny = fog_types.shape
    splits = share > 0.0 or lower_share > 0.0
    changed = 0
    for ix in range(max(ix0, 0), min(ix1, nx)):
        for iy in range(max(iy0, 0), min(iy1, ny)):
            if fog_types[ix, iy] != _FLOOR:
                continue
            h = fog_heights[ix, iy]
            if (
                (
                    splits
                    and _split_edge(
                        split_frames,
                        lower_split_frames,
                        multi_frames,
                        ix,
                        iy,
                        share,
                        lower_share,
                        contrast,
                    )
                )
                or (min_frames > 0 and _weak_foot(floor, frame_votes, ix, iy, h, min_frames, band))
                or (
                    rims
                    and _uncovered_rim(
                        floor,
                        cover_ends,
                        cover_passes,
                        split_frames,
                        lower_split_frames,
                        ix,
                        iy,
                        h,
                        min_rays,
                        pass_fraction,
                        eps,
                        inward,
                    )
                )
            ):
                fog_types[ix, iy] = _UNKNOWN
                fog_heights[ix, iy] = np.nan
                changed += 1
    return changed
