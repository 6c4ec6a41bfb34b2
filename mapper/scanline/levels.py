"""Level regions grown over row segments: the horizontal model ``z = h`` (heights [m]).

The heights are the pixels' points' z in the tilt-corrected robot frame, with their noise along
z (`mapper.scanline.points.level_geometry`); the row segments are those the planes grow over
(`mapper.scanline.rows`).

- `split_level`: segments split where their heights step (a row running along a low step's
  side edge, straight in depth when noise hides the small depth jump there);
- `horizontal_sums`: each segment's weighted sums of the model;
- `grow_floors`: floors seeded from level segments, the best-determined first, grown
  breadth-first into touching level segments whose mean height agrees with the floor's (and
  touching floors that agree merged, `_merge_floors`). The model cannot tilt, so it cannot creep
  up a staircase tread by tread as a free plane can when noise hides each small step;
- `level_heights`: each region's height from its grown segments.

`mapper.scanline.floors` then measures each region and judges which are floors.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from mapper.scanline.regions import _overlap, _row_index, _stable_order


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def horizontal_sums(points, sigma_z, seg_rows, seg_starts, seg_stops, correlation):
    """(S, 6) sums of every segment for the horizontal model ``z = h``.

    Columns: Σw, Σw·z, Σw·z², n, Σw·x, Σw·y with w = 1/(correlation·sigma_z²) (points:
    (H, W, 3) points of the pixels in the tilt-corrected robot frame [m], sigma_z: their noise
    along z [m]). ``correlation`` (≥ 1, 1 for white noise) is the factor by which correlated
    noise inflates the variance of a mean over many pixels of a row: 1/Σw is then the squared
    standard error of the segment's mean height, and a pixel-level χ² is τ·(Σw·z² − (Σw·z)²/Σw).
    """
    n_seg = seg_rows.shape[0]
    out = np.empty((n_seg, 6))
    for i in range(n_seg):
        r = seg_rows[i]
        # Summed in registers from 0 in pixel order (the same sums as adding into the row).
        sw = swz = swzz = n = swx = swy = 0.0
        for c in range(seg_starts[i], seg_stops[i]):
            w = 1.0 / (correlation * sigma_z[r, c] * sigma_z[r, c])
            z = points[r, c, 2]
            sw += w
            swz += w * z
            swzz += w * z * z
            n += 1.0
            swx += w * points[r, c, 0]
            swy += w * points[r, c, 1]
        out[i, 0] = sw
        out[i, 1] = swz
        out[i, 2] = swzz
        out[i, 3] = n
        out[i, 4] = swx
        out[i, 5] = swy
    return out


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def grow_floors(
    seg_rows,
    seg_starts,
    seg_stops,
    seg_hsums,
    height,
    sigma_factor,
    chi_factor,
    tolerance_m,
    seed_min_pixels,
    correlation,
):
    """Region growing of horizontal floors (``z = h``, one parameter) over row segments.

    A segment is *level* when its points' heights scatter about their mean within
    ``chi_factor`` times their noise (RMS in sigma units). Level segments seed floors, the
    best-determined first (smallest standard error of the mean height), and floors grow
    breadth-first into touching level segments (rows above, below, same row) whose mean height
    agrees with the floor's running mean within ``sigma_factor`` standard errors (of both)
    plus ``tolerance_m``. The model cannot tilt, so it cannot creep up a staircase tread by
    tread as a free plane can when noise hides each small step.

    Args:
        seg_rows: (S,) row of each segment (output of `split_rows`).
        seg_starts: (S,) first column of each segment.
        seg_stops: (S,) column after the last of each segment.
        seg_hsums: (S, 4) sums of `horizontal_sums`.
        height: image height [px].
        sigma_factor: mean heights must agree within this many standard errors.
        chi_factor: a level segment's RMS height residual is at most this many sigma.
        tolerance_m: constant added to the height tolerance [m].
        seed_min_pixels: minimum length of a seed segment.
        correlation: the noise's variance inflation of means (`horizontal_sums`).

    Returns:
        (S,) int64 floor index of every segment, -1 for none; floors numbered in creation
        order.
    """
    n_seg = seg_rows.shape[0]
    floor_of = np.full(n_seg, -1, np.int64)
    if n_seg == 0:
        return floor_of
    row_first = _row_index(seg_rows, height)
    mean = np.zeros(n_seg)
    variance = np.full(n_seg, np.inf)  # squared standard error of the mean height
    level = np.zeros(n_seg, np.bool_)
    for i in range(n_seg):
        w, wz, wzz, n = seg_hsums[i, 0], seg_hsums[i, 1], seg_hsums[i, 2], seg_hsums[i, 3]
        if not w > 0.0 or n < 3.0:
            continue
        mean[i] = wz / w
        variance[i] = 1.0 / w
        chi2 = correlation * max(wzz - wz * mean[i], 0.0) / (n - 1.0)
        level[i] = chi2 <= chi_factor * chi_factor
    order = _stable_order(variance)
    queue = np.empty(n_seg, np.int64)
    n_floors = np.int64(0)  # not the literal 0: _merge_floors would compile for both
    for s in order:
        if not level[s] or floor_of[s] >= 0 or seg_stops[s] - seg_starts[s] < seed_min_pixels:
            continue
        label = n_floors
        n_floors += 1
        floor_of[s] = label
        total_w = seg_hsums[s, 0]
        total_wz = seg_hsums[s, 1]
        head = 0
        tail = 1
        queue[0] = s
        while head < tail:
            q = queue[head]
            head += 1
            rq = seg_rows[q]
            for rr in (rq - 1, rq, rq + 1):
                if rr < 0 or rr >= height:
                    continue
                gap = 1 if rr == rq else 0
                for t in range(row_first[rr], row_first[rr + 1]):
                    if floor_of[t] >= 0 or not level[t]:
                        continue
                    if not _overlap(seg_starts[q], seg_stops[q], seg_starts[t], seg_stops[t], gap):
                        continue
                    floor_mean = total_wz / total_w
                    tol = sigma_factor * math.sqrt(variance[t] + 1.0 / total_w) + tolerance_m
                    if abs(mean[t] - floor_mean) <= tol:
                        floor_of[t] = label
                        queue[tail] = t
                        tail += 1
                        total_w += seg_hsums[t, 0]
                        total_wz += seg_hsums[t, 1]
        # Members that took part while the mean was still uncertain and no longer fit the
        # final one leave the floor (the rows blending a tread with its riser).
        floor_mean = total_wz / total_w
        for k in range(tail):
            t = queue[k]
            tol = sigma_factor * math.sqrt(variance[t] + 1.0 / total_w) + tolerance_m
            if abs(mean[t] - floor_mean) > tol:
                floor_of[t] = -2
    for i in range(n_seg):
        if floor_of[i] == -2:
            floor_of[i] = -1
    _merge_floors(
        floor_of,
        n_floors,
        seg_rows,
        seg_starts,
        seg_stops,
        seg_hsums,
        height,
        sigma_factor,
        tolerance_m,
    )
    return floor_of


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _merge_floors(
    floor_of,
    n_floors,
    seg_rows,
    seg_starts,
    seg_stops,
    seg_hsums,
    height,
    sigma_factor,
    tolerance_m,
):
    """Merge touching floors whose mean heights agree as growing requires (in place).

    Growing compares segments with the running mean, so a large level surface whose far rows
    sit a few millimetres off its near ones (residual tilt) can end up in two floors; their
    means still agree within the growing tolerance. Only floors of at least 3 segments merge
    (a row blending a tread with its riser must not bridge the two). Floors are renumbered in
    order of their first segment.
    """
    if n_floors < 2:
        return
    parent = np.arange(n_floors)
    total_w = np.zeros(n_floors)
    total_wz = np.zeros(n_floors)
    n_segments = np.zeros(n_floors, np.int64)
    for i in range(seg_rows.shape[0]):
        if floor_of[i] >= 0:
            total_w[floor_of[i]] += seg_hsums[i, 0]
            total_wz[floor_of[i]] += seg_hsums[i, 1]
            n_segments[floor_of[i]] += 1
    row_first = _row_index(seg_rows, height)
    for i in range(seg_rows.shape[0]):
        if floor_of[i] < 0:
            continue
        r = seg_rows[i]
        for rr in (r, r + 1):
            if rr >= height:
                continue
            gap = 1 if rr == r else 0
            for t in range(row_first[rr], row_first[rr + 1]):
                if floor_of[t] < 0 or t == i:
                    continue
                if not _overlap(seg_starts[i], seg_stops[i], seg_starts[t], seg_stops[t], gap):
                    continue
                a = floor_of[i]
                while parent[a] != a:
                    a = parent[a]
                b = floor_of[t]
                while parent[b] != b:
                    b = parent[b]
                if a == b or n_segments[a] < 3 or n_segments[b] < 3:
                    continue
                difference = abs(total_wz[a] / total_w[a] - total_wz[b] / total_w[b])
                tol = sigma_factor * math.sqrt(1.0 / total_w[a] + 1.0 / total_w[b]) + tolerance_m
                if difference <= tol:
                    keep, gone = min(a, b), max(a, b)
                    parent[gone] = keep
                    total_w[keep] += total_w[gone]
                    total_wz[keep] += total_wz[gone]
                    n_segments[keep] += n_segments[gone]
    new_id = np.full(n_floors, -1, np.int64)
    count = 0
    for i in range(seg_rows.shape[0]):
        if floor_of[i] < 0:
            continue
        a = floor_of[i]
        while parent[a] != a:
            a = parent[a]
        if new_id[a] < 0:
            new_id[a] = count
            count += 1
        floor_of[i] = new_id[a]


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def split_level(z, sigma_z, seg_rows, seg_starts, seg_stops, step_factor, min_pixels, correlation):
    """Split row segments where their height steps (for the horizontal model).

    A row running along a low step's side edge is one straight line in depth when noise
    hides the small depth jump there, but its heights then step by the step's height. Each
    segment is split, recursively, at the boundary with the largest difference of the
    weighted mean heights left and right of it, when that difference exceeds ``step_factor``
    of its standard error; pieces keep at least ``min_pixels`` pixels.

    Args:
        z: (H, W) heights of the pixels' points [m] (tilt-corrected robot frame).
        sigma_z: (H, W) their noise along z [m].
        seg_rows: (S,) row of each segment (output of `split_rows`).
        seg_starts: (S,) first column of each segment.
        seg_stops: (S,) column after the last of each segment.
        step_factor: a height step of more than this many standard errors splits.
        min_pixels: shortest piece.
        correlation: the noise's variance inflation of means (`horizontal_sums`).

    Returns:
        rows, starts, stops of the pieces (int64, sorted by row then column).
    """
    width = z.shape[1]
    n_seg = seg_rows.shape[0]
    cap = n_seg + n_seg * (width // max(min_pixels, 1) + 1)
    rows = np.empty(cap, np.int64)
    starts = np.empty(cap, np.int64)
    stops = np.empty(cap, np.int64)
    count = 0
    stack = np.empty((width + 2, 2), np.int64)
    w_pre = np.zeros(width + 1)
    wz_pre = np.zeros(width + 1)
    for i in range(n_seg):
        r = seg_rows[i]
        stack[0, 0] = seg_starts[i]
        stack[0, 1] = seg_stops[i]
        top = 1
        while top > 0:  # depth first, left piece on top: pieces come out left to right
            top -= 1
            a = stack[top, 0]
            b = stack[top, 1]
            n = b - a
            for k in range(a, b):
                w = 1.0 / (sigma_z[r, k] * sigma_z[r, k])
                w_pre[k - a + 1] = w_pre[k - a] + w
                wz_pre[k - a + 1] = wz_pre[k - a] + w * z[r, k]
            best = 0.0
            split = -1
            for m in range(min_pixels, n - min_pixels + 1):
                w_left = w_pre[m]
                w_right = w_pre[n] - w_pre[m]
                difference = (wz_pre[n] - wz_pre[m]) / w_right - wz_pre[m] / w_left
                t = abs(difference) / math.sqrt(correlation * (1.0 / w_left + 1.0 / w_right))
                if t > best:
                    best = t
                    split = a + m
            if split > 0 and best > step_factor:
                stack[top, 0] = split
                stack[top, 1] = b
                stack[top + 1, 0] = a
                stack[top + 1, 1] = split
                top += 2
                continue
            rows[count] = r
            starts[count] = a
            stops[count] = b
            count += 1
    return rows[:count].copy(), starts[:count].copy(), stops[:count].copy()


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def level_heights(floor_of_segment, seg_hsums, n_floors):
    """(F,) each level region's height: its grown segments' weighted mean height [m].

    ``Σ sums[:, 1] / Σ sums[:, 0]`` over the region's segments in segment order (as
    ``np.bincount`` sums; `horizontal_sums` columns: weight, weighted height); NaN for a
    region without segments.
    """
    weighted = np.zeros(n_floors)
    weights = np.zeros(n_floors)
    for i in range(floor_of_segment.shape[0]):
        f = floor_of_segment[i]
        if f >= 0:
            weighted[f] += seg_hsums[i, 1]
            weights[f] += seg_hsums[i, 0]
    return weighted / weights
