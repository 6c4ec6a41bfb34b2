"""2.5D floor height map: verification (eq. 8) and update (eq. 9, with votes), in the affected area.

Invalid floor heights are stored as NaN (the paper's −∞). The cell of a height ``h`` in column
``(ix, iy)`` is layer ``floor((h - z_min) / layer)``; a height outside the grid's z range has no
cell, so it is treated as unsupported (``OG = 0.5`` outside the grid, eq. 4).

Eq. 9 as the paper's sentences describe it (its typeset form is garbled), for a point with floor
height ``h`` whose cell passes eq. 7 (``OG(x, y, h) > p_occ``):

- stored floor invalid → ``h``;
- ``h > Floor + ε`` → ``h`` (a higher surface replaces the lower one);
- ``h < Floor − ε`` → unchanged (lower surfaces are ignored);
- otherwise → ``ν·Floor + (1 − ν)·h``.

Beyond the paper, each stored height holds votes (`MapperParams.floor_vote_cap`): points
within ``±ε`` add one (up to the cap), points of another surface — higher *or* lower — take one
away, and that surface replaces the stored height only when no vote is left. The paper's rule
(cap 0) lets a single stray point of a higher surface take a cell for good: noise carries a
tread's points a few cm into the lower tread's last column, a rough top taken for a plane in
one frame stays a floor. With votes, a cell holds the surface most of its points come from.

Points that are not floor count too (beyond the paper, votes only): a point more than ``ε``
above the stored floor, in a layer above the floor's whose cell is occupied (eq. 7 at the
point's z), and at most ``δ`` above it (higher, eq. 11 makes the cell an obstacle whatever the
floor), shows a surface above the stored one. In a column a frame sees mostly above its
floor (such points and floor points of a higher surface are more than `ABOVE_RATIO` times
the points at the floor's height), each such point takes one vote away (down to 0, never
replacing the floor: it has no plane height), before the frame's floor points; the next
floor point of another surface then replaces it. A column the frame sees partly at the
floor's height keeps its votes: a riser inside the cell at a step's edge (3 of the cell's
4 cm the lower tread, stage depth seed 1: the sill's front cells took the sill's height when
every such point counted).
Without this a stored lower floor outlived the surface above it whenever that surface was
seen mostly as points that are not floor: the stage_zigzag sill's interior cells took the
ground's height from far frames whose stereo showed no sill there (up to 39 votes), and the
sill top's few floor points a frame never took them back: on stereo seed 8, with the
pipeline's anchor rule, the sill row was 19.3 mm off (4.8 mm before the rule; 1.8 mm with
this one). Within the floor's own layer
the occupancy cannot tell a surface from the floor's own noisy points, so they do not count.

Beyond the paper too, each frame gives a verdict on every stored floor it sees
(`frame_verdicts`, `MapperParams.floor_frame_cap`): a rough top that one frame took for a plane
is seen as no plane — points at its height that are not floor — by most other frames, and
those frames remove it; a floor seen as a plane in most frames keeps its votes.

Beyond the paper too, a height within ``±ε`` of the stored floor is averaged in as one frame's
measurement (`MapperParams.floor_memory`) rather than smoothed by ``ν`` per point: every point
of a plane carries the plane's one height, so eq. 9 per point counts one frame's measurement
as many times as the plane has points in the cell (6–10 on the stage's sill at 1.2 m), and
with ``ν = 0.93`` (``0.93^8 ≈ 0.56``) the stored height is mostly the last one or two
frames'. The last frame is no better than the others: on the stage's stereo replays a
surface's height scatters from frame to frame by 3.7 mm (SD) at 1.0–1.3 m and 7.5 mm at
1.6–2 m, mostly the camera pose's error, with a lag-one autocorrelation of 0.0–0.3 — noise
that a mean cures (stereo seed 4: the sill's last frame before the robot stepped over it was
+9.6 mm off, the map kept +5.5 mm; the mean of its 36 frames is −2.5 mm). So each point
carries ``w / n`` of a frame, where ``n`` is the number of the frame's usable floor points in
the column (eq. 7) and ``w = (WEIGHT_RANGE_M / r)^p`` at their mean range ``r`` (at most 1, ``p`` =
`MapperParams.floor_range_power`) weighs far frames down, as stereo noise grows with range;
the stored height is the weighted mean ``F ← F + w/(W + w)·(h − F)`` with
``W ← min(W + w, memory)``, so the mean forgets at the rate of ``memory`` frames and a
surface that slowly moves is followed. A stored height replaced (invalid, a higher surface,
no vote left) starts a new mean with the replacing point's weight.

Points are applied one after the other in input order (deterministic).
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

#: Points that are not floor a column needs within ``±eps`` of its floor for `frame_verdicts` to
#: call it level there. A few points are level whatever the surface: a tread's edge points
#: spilled into the lower tread's last column, or a sill's into the ground it hides, kept
#: the higher height there (replays, seeds 1–8, unsafe cells mean: stairs 104.4 → 106.5 with
#: 1 point, 104.5 with 3; stage_zigzag 78.9 → 86.1 with 1, 81.6 with 3, seeds 3–5 as without
#: the rule but one cell with 5). moving_box's box top gives 5–9 points a column a frame at
#: 1.3 m: with 7, seed 2's box row is 60 mm off again.
LEVEL_MIN_POINTS = 5
#: How many times the points at a stored floor's height the points showing a surface above it
#: (and floor points of a higher surface) must be in a frame's column for them to take the
#: floor's votes (`_drain_covered`). 2: a riser inside the cell at a step's edge is seen as
#: about as many points above the lower tread as at it (stage depth seed 1, the sill's front
#: column: with 1 its cells took the sill's height, unsafe cells 22 → 31); a surface covering
#: the cell shows few or none at the floor's height.
ABOVE_RATIO = 2
#: Range [m] up to which a frame's floor height counts as one whole frame in the weighted mean
#: (`update_floor` with `MapperParams.floor_memory`); farther, it counts
#: ``(WEIGHT_RANGE_M / range)^floor_range_power``. 1 m: the nearest floor the stage's head
#: camera sees (88 × 72, 39° vertical) is about 1.1 m away.
WEIGHT_RANGE_M = 1.0


@numba.njit(cache=True, inline="always")
def _layer_of(h: float, z_min: float, layer: float, nz: int) -> int:
    k = int(np.floor((h - z_min) / layer))
    if k < 0 or k >= nz:
        return -1
    return k


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def verify_floor(
    floor: NDArray[np.float64],
    og: NDArray[np.uint8],
    occ_level: int,
    z_min: float,
    layer: float,
    ix0: int,
    ix1: int,
    iy0: int,
    iy1: int,
) -> int:
    """Eq. 8 in ``[ix0, ix1) × [iy0, iy1)``: invalidate floors whose cell is not above p_occ.

    Returns:
        How many floor heights were invalidated.
    """
    nz = og.shape[2]
    removed = 0
    for ix in range(ix0, ix1):
        for iy in range(iy0, iy1):
            h = floor[ix, iy]
            if np.isnan(h):
                continue
            k = _layer_of(h, z_min, layer, nz)
            if k < 0 or og[ix, iy, k] <= occ_level:
                floor[ix, iy] = np.nan
                removed += 1
    return removed


@numba.njit(cache=True, inline="always")
def _supported(og_flat, col: int, h: float, z_min: float, layer: float, nz: int, occ_level: int):
    """Eq. 7: whether the cell of height ``h`` in column ``col`` is occupied."""
    k = _layer_of(h, z_min, layer, nz)
    return k >= 0 and og_flat[col * nz + k] > occ_level


@numba.njit(cache=True, inline="always")
def _covers(
    og_flat,
    col: int,
    z: float,
    f: float,
    eps: float,
    delta: float,
    z_min: float,
    layer: float,
    nz: int,
    occ_level: int,
):
    """Whether a point at ``z`` that is not floor shows a surface above the stored floor ``f``.

    It does when it lies more than ``eps`` and at most ``delta`` (eq. 11's obstacle threshold)
    above ``f`` in a layer above ``f``'s and its cell is occupied (eq. 7 at ``z``): the column
    holds something higher than the stored floor that the FOG would not show (more than
    ``delta`` above the floor, eq. 11 makes the cell an obstacle whatever the floor: a box on
    the ground, whose rough top a frame may take for a plane, must not take the ground's
    votes). Within ``f``'s own layer the occupancy cannot tell a surface from the floor's own
    noisy points. A NaN ``f`` never.
    """
    if not (z > f + eps and z <= f + delta):
        return False
    k = _layer_of(z, z_min, layer, nz)
    return k > _layer_of(f, z_min, layer, nz) and og_flat[col * nz + k] > occ_level


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _drain_covered(
    og_flat: NDArray[np.uint8],
    votes_flat: NDArray[np.int32],
    floor_flat: NDArray[np.float64],
    point_cell: NDArray[np.int64],
    points: NDArray[np.float64],
    floor_heights: NDArray[np.float64],
    eps: float,
    delta: float,
    z_min: float,
    layer: float,
    nz: int,
    occ_level: int,
) -> None:
    """Take the votes of stored floors a frame sees covered by a surface above (module doc).

    Per column with a valid floor ``F``: ``above`` counts the points that are not floor and
    show a surface above it (`_covers`), ``higher`` the floor points more than ``eps`` above
    it, ``level`` the points at its height (floor points with ``|h − F| <= eps``, others with
    ``|z − F| <= eps``). When ``above + higher > ABOVE_RATIO·level`` (the frame sees the
    column mostly above the floor) its ``above`` points take one vote each (down to 0);
    ``higher``'s are counted by eq. 9's loop as before. A column split between the floor and a
    surface above (a riser inside a cell at a step's edge) keeps its votes.
    """
    n_cols = floor_flat.shape[0]
    above = np.zeros(n_cols, dtype=np.int32)
    level = np.zeros(n_cols, dtype=np.int32)
    higher = np.zeros(n_cols, dtype=np.int32)
    for i in range(point_cell.shape[0]):
        col = point_cell[i]
        if col < 0 or votes_flat[col] <= 0:
            continue
        f = floor_flat[col]
        if np.isnan(f):
            continue
        h = floor_heights[i]
        if np.isfinite(h):
            if abs(h - f) <= eps:
                level[col] += 1
            elif h > f + eps:
                higher[col] += 1
        elif abs(points[i, 2] - f) <= eps:
            level[col] += 1
        elif _covers(og_flat, col, points[i, 2], f, eps, delta, z_min, layer, nz, occ_level):
            above[col] += 1
    # Once per column the frame touched (``above`` zeroed once applied), not over the grid.
    for i in range(point_cell.shape[0]):
        col = point_cell[i]
        if col < 0 or above[col] == 0:
            continue
        if above[col] + higher[col] > ABOVE_RATIO * level[col]:
            votes_flat[col] = max(votes_flat[col] - above[col], 0)
        above[col] = 0


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _point_shares(
    og_flat: NDArray[np.uint8],
    point_cell: NDArray[np.int64],
    points: NDArray[np.float64],
    floor_heights: NDArray[np.float64],
    sensor_origin: NDArray[np.float64],
    occ_level: int,
    z_min: float,
    layer: float,
    nz: int,
    range_power: float,
) -> NDArray[np.float64]:
    """Per column, the weight each of the frame's usable floor points (eq. 7) carries there.

    The frame's weight in a column is ``(WEIGHT_RANGE_M / r)^range_power`` (at most 1) at the
    mean range ``r`` of those points, shared equally among them: one power per column, not
    per point (a power per point took 0.07 of the kernel's 0.13 ms on a 88 × 72 frame).
    """
    count = np.zeros(og_flat.shape[0] // nz, dtype=np.int32)
    shares = np.zeros(count.shape[0])  # the sum of the points' ranges first
    for i in range(point_cell.shape[0]):
        col = point_cell[i]
        h = floor_heights[i]
        if col >= 0 and np.isfinite(h) and _supported(og_flat, col, h, z_min, layer, nz, occ_level):
            dx = points[i, 0] - sensor_origin[0]
            dy = points[i, 1] - sensor_origin[1]
            dz = points[i, 2] - sensor_origin[2]
            count[col] += 1
            shares[col] += np.sqrt(dx * dx + dy * dy + dz * dz)
    for col in range(count.shape[0]):
        n = count[col]
        if n > 0:
            r = shares[col] / n
            weight = 1.0 if r <= WEIGHT_RANGE_M else (WEIGHT_RANGE_M / r) ** range_power
            shares[col] = weight / n
    return shares


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def update_floor(
    floor: NDArray[np.float64],
    weights: NDArray[np.float64],
    votes: NDArray[np.int32],
    frame_votes: NDArray[np.int32],
    og: NDArray[np.uint8],
    point_cell: NDArray[np.int64],
    points: NDArray[np.float64],
    floor_heights: NDArray[np.float64],
    sensor_origin: NDArray[np.float64],
    occ_level: int,
    z_min: float,
    layer: float,
    eps: float,
    nu: float,
    vote_cap: int,
    memory: float,
    range_power: float,
    delta: float,
) -> tuple[int, int]:
    """Eq. 9 for every inserted point with a finite floor height, with per-cell votes.

    With ``memory > 0`` a height within ``±eps`` of the stored floor is averaged in (module doc,
    "weighted mean") instead of smoothed by ``nu``. With ``vote_cap > 0`` a point that is not
    floor and shows a surface above the stored floor (`_covers`) takes one of its votes away
    (module doc).

    Args:
        floor: (nx, ny) floor heights [m], NaN = invalid; updated in place.
        weights: (nx, ny) weight of each stored floor height [frames at `WEIGHT_RANGE_M`],
            at most ``memory``; updated in place (only with ``memory > 0``), meaningless where
            the floor is invalid.
        votes: (nx, ny) evidence for each stored floor height (see `MapperParams.floor_vote_cap`);
            updated in place, meaningless where the floor is invalid.
        frame_votes: (nx, ny) frame votes (`frame_verdicts`): set to 1 where a floor height
            is stored anew.
        og: (nx, ny, nz) occupancy levels (already updated with this frame).
        point_cell: (N,) column index ``ix*ny + iy`` of each point, negative if dropped.
        points: (N, 3) world points [m] (their range weighs them; the z of those that are not
            floor tells a surface above the stored floor).
        floor_heights: (N,) height ``h`` of each point's horizontal plane [m]; non-finite =
            not floor.
        sensor_origin: (3,) camera centre in the world [m].
        occ_level: Occupied iff level > occ_level (eq. 7).
        z_min: World z of the grid's lowest face [m].
        layer: Layer height [m].
        eps: Gate of eq. 9 [m].
        nu: Smoothing factor of eq. 9 per point (only with ``memory == 0``).
        vote_cap: The most votes a stored floor height holds (`MapperParams.floor_vote_cap`);
            0 = the paper's eq. 9.
        memory: The most weight a stored floor height holds (`MapperParams.floor_memory`);
            0 = the paper's smoothing by ``nu``.
        range_power: How a frame's weight falls with range (`MapperParams.floor_range_power`).
        delta: Obstacle threshold of eq. 11 [m]: a point that is not floor more than this above
            the stored floor shows no surface above it (`_covers`).

    Returns:
        (floor points used, floor points rejected by eq. 7).
    """
    nz = og.shape[2]
    # Flat views: column ``col = ix*ny + iy`` is ``floor_flat[col]`` and its layer k is
    # ``og_flat[col*nz + k]`` (C order), so no integer division per point.
    og_flat = og.reshape(-1)
    floor_flat = floor.reshape(-1)
    weights_flat = weights.reshape(-1)
    votes_flat = votes.reshape(-1)
    frames_flat = frame_votes.reshape(-1)
    averaged = memory > 0.0
    shares = (
        _point_shares(
            og_flat,
            point_cell,
            points,
            floor_heights,
            sensor_origin,
            occ_level,
            z_min,
            layer,
            nz,
            range_power,
        )
        if averaged
        else np.zeros(0)
    )
    if vote_cap > 0:
        _drain_covered(
            og_flat,
            votes_flat,
            floor_flat,
            point_cell,
            points,
            floor_heights,
            eps,
            delta,
            z_min,
            layer,
            nz,
            occ_level,
        )
    used = 0
    rejected = 0
    for i in range(point_cell.shape[0]):
        col = point_cell[i]
        h = floor_heights[i]
        if col < 0 or not np.isfinite(h):
            continue
        if not _supported(og_flat, col, h, z_min, layer, nz, occ_level):
            rejected += 1
            continue
        used += 1
        w = shares[col] if averaged else 0.0
        f = floor_flat[col]
        if np.isnan(f):
            floor_flat[col] = h
            weights_flat[col] = w
            votes_flat[col] = 1
            frames_flat[col] = 1
        elif h <= f + eps and h >= f - eps:
            if averaged:
                total = weights_flat[col] + w
                floor_flat[col] = f + (w / total) * (h - f)
                weights_flat[col] = min(total, memory)
            else:
                floor_flat[col] = nu * f + (1.0 - nu) * h
            votes_flat[col] = min(votes_flat[col] + 1, max(vote_cap, 1))
        elif vote_cap == 0:
            if h > f + eps:  # the paper: a higher surface replaces, a lower one is ignored
                floor_flat[col] = h
                weights_flat[col] = w
        else:  # another surface: one vote away, replaced when none is left
            votes_flat[col] -= 1
            if votes_flat[col] <= 0:
                floor_flat[col] = h
                weights_flat[col] = w
                votes_flat[col] = 1
                frames_flat[col] = 1
    return used, rejected


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def frame_verdicts(
    floor: NDArray[np.float64],
    frame_votes: NDArray[np.int32],
    point_cell: NDArray[np.int64],
    points_z: NDArray[np.float64],
    floor_heights: NDArray[np.float64],
    eps: float,
    frame_cap: int,
) -> int:
    """One frame's verdict on every stored floor it sees (beyond the paper), before eq. 9.

    In each column with a valid floor ``F`` the frame counts its floor points within ``±eps``
    of ``F`` (for it) and its points that are not floor with ``F − eps <= z <= F`` (against it:
    the surface is there but does not look like a plane; points above ``F`` are left out, as
    a riser or a foot standing on the floor puts them there). A frame with more against than
    for takes one of the column's frame votes away, and the floor is invalidated when none is
    left; a frame with more for adds one, up to ``frame_cap``. A rough top that one frame took
    for a plane is thus removed by the frames that see it rough.

    A frame whose points that are not floor within ``±eps`` of ``F`` — at least
    `LEVEL_MIN_POINTS` of them — lie within ``eps`` of each other says nothing: in this column
    they are level at the floor's height, so the
    segmentation's "no plane" came from elsewhere in the region (moving_box: the 6 cm box top,
    a region of 260 pixels at 1.3 m whose RMS ratio hovers about the 1.05 limit, is a floor in
    every other frame; the other frames took the floor away and the box top showed as an
    obstacle or not at all). A rough top's bumps (up to 10 cm in 8 cm, stage) spread the
    points of a 4 cm column over more than ``eps``.

    Args:
        floor: (nx, ny) floor heights [m], NaN = invalid; updated in place.
        frame_votes: (nx, ny) frame votes of the stored floors; updated in place.
        point_cell: (N,) column index ``ix*ny + iy`` of each point, negative if dropped.
        points_z: (N,) world z of each point [m].
        floor_heights: (N,) height ``h`` of each point's plane [m]; non-finite = not floor.
        eps: Gate of eq. 9 [m].
        frame_cap: Most frame votes a floor holds (`MapperParams.floor_frame_cap`); 0 = off.

    Returns:
        How many floor heights were invalidated.
    """
    if frame_cap == 0:
        return 0
    floor_flat = floor.reshape(-1)
    votes_flat = frame_votes.reshape(-1)
    support = np.zeros(floor_flat.shape[0], dtype=np.int32)
    against = np.zeros(floor_flat.shape[0], dtype=np.int32)
    # Lowest and highest non-floor point within ±eps of the floor, and how many, per column.
    low = np.full(floor_flat.shape[0], np.inf)
    high = np.full(floor_flat.shape[0], -np.inf)
    near = np.zeros(floor_flat.shape[0], dtype=np.int32)
    for i in range(point_cell.shape[0]):
        col = point_cell[i]
        if col < 0:
            continue
        f = floor_flat[col]
        h = floor_heights[i]
        z = points_z[i]
        if np.isfinite(h):
            if abs(h - f) <= eps:  # NaN floor: never
                support[col] += 1
        elif abs(z - f) <= eps:
            low[col] = min(low[col], z)
            high[col] = max(high[col], z)
            near[col] += 1
            if z <= f:
                against[col] += 1
    removed = 0
    for col in range(floor_flat.shape[0]):
        if against[col] > support[col]:
            if near[col] >= LEVEL_MIN_POINTS and high[col] - low[col] <= eps:
                continue  # level at the floor's height: no verdict
            votes_flat[col] -= 1
            if votes_flat[col] <= 0:
                floor_flat[col] = np.nan
                removed += 1
        elif support[col] > 0:
            votes_flat[col] = min(votes_flat[col] + 1, frame_cap)
    return removed
