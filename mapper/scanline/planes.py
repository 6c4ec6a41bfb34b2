"""Planes grown over row segments in the image's inverse-depth model (image frame).

A plane ``n·p = h`` seen by a pinhole camera has an inverse depth that is affine in the
normalised pixel coordinates, ``1/d = A·x + B·y + C`` with ``(A, B, C) = n/h`` (camera frame),
and a straight 3D line on it has ``1/d = a + b·x`` along an image row. Fitting these linear
models by least squares puts the error where a depth camera has it (along the viewing ray), so
fitted planes are not tilted towards the rays as a 3D total-least-squares fit of ray-smeared
points is; every tolerance is a depth difference [m].

`segment_sums` / `grow_planes`: seeds are three overlapping segments in adjacent rows that fit
one plane, taken best-fitting first; planes grow breadth-first into touching segments (rows
above, below, same row) whose end points and RMS fit the current plane within tolerances made
of the segment's noise and the plane's prediction uncertainty; the plane is refit (from
per-segment moment sums, `_solve_plane`) after every accepted segment.

`reassign_segments`: segments move to a touching plane that fits them clearly better.

A plane's fit (`_solve_plane`, a row of the plane table of `mapper.scanline.plane_pixels`): A, B,
C, the residual variance of the inverse depth [1/m²] and the inverse normal matrix (13 values).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from mapper.scanline.regions import _depth_gap, _overlap, _row_index, _stable_order

_N_SUMS = 10  # n, sx, sy, sxx, sxy, syy, sz, sxz, syz, szz (z = inverse depth)

# Constant arguments: numpy scalars, not literals (`mapper.scanline`).
_NO_GAP = np.int64(0)  # `_overlap`'s gap between segments of adjacent rows (must overlap)
_GROWING = np.bool_(True)  # `_segment_misfit` of a growing plane (its uncertainty counts)
_SEED_TEST = np.bool_(False)  # `_segment_misfit` of a seed's own plane (segment noise only)


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _solve_plane(sums, out):
    """Inverse-depth plane from sums: out = [A, B, C, s², inv(M) as 9 values]; False if singular.

    s² is the residual variance of the inverse depth [1/m²].
    """
    n = sums[0]
    m00 = sums[3]
    m01 = sums[4]
    m02 = sums[1]
    m11 = sums[5]
    m12 = sums[2]
    m22 = n
    c00 = m11 * m22 - m12 * m12
    c01 = m02 * m12 - m01 * m22
    c02 = m01 * m12 - m02 * m11
    det = m00 * c00 + m01 * c01 + m02 * c02
    scale = m00 * m11 * m22
    if n < 3.0 or not det > 1e-12 * scale:
        return False
    c11 = m00 * m22 - m02 * m02
    c12 = m01 * m02 - m00 * m12
    c22 = m00 * m11 - m01 * m01
    i00 = c00 / det
    i01 = c01 / det
    i02 = c02 / det
    i11 = c11 / det
    i12 = c12 / det
    i22 = c22 / det
    v0 = sums[7]
    v1 = sums[8]
    v2 = sums[6]
    a = i00 * v0 + i01 * v1 + i02 * v2
    b = i01 * v0 + i11 * v1 + i12 * v2
    c = i02 * v0 + i12 * v1 + i22 * v2
    rss = sums[9] - (a * v0 + b * v1 + c * v2)
    out[0] = a
    out[1] = b
    out[2] = c
    out[3] = max(rss, 0.0) / max(n - 3.0, 1.0)
    out[4] = i00
    out[5] = i01
    out[6] = i02
    out[7] = i01
    out[8] = i11
    out[9] = i12
    out[10] = i02
    out[11] = i12
    out[12] = i22
    return True


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _predict_sigma_depth(plane, x, yv, inv_pred):
    """Standard deviation [m] of the plane's predicted depth at (x, y)."""
    g0 = x
    g1 = yv
    quad = (
        g0 * (plane[4] * g0 + plane[5] * g1 + plane[6])
        + g1 * (plane[7] * g0 + plane[8] * g1 + plane[9])
        + (plane[10] * g0 + plane[11] * g1 + plane[12])
    )
    return math.sqrt(max(plane[3] * quad, 0.0)) / (inv_pred * inv_pred)


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _residual_square_sum(plane, sums, i, o):
    """Σ (z − A·x − B·y − C)² from moment sums ``sums[i, o:o + 10]`` (a segment's, weighted).

    Row and offset, not a slice: a view per call costs more than this sum.
    """
    pa = plane[0]
    pb = plane[1]
    pc = plane[2]
    total = (
        sums[i, o + 9]
        - 2.0 * (pa * sums[i, o + 7] + pb * sums[i, o + 8] + pc * sums[i, o + 6])
        + pa * pa * sums[i, o + 3]
        + pb * pb * sums[i, o + 5]
        + pc * pc * sums[i, o + 0]
        + 2.0 * (pa * pb * sums[i, o + 4] + pa * pc * sums[i, o + 1] + pb * pc * sums[i, o + 2])
    )
    return max(total, 0.0)


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _segment_rms(plane, seg_sums, i):
    """RMS depth residual [m] of segment i against a plane, from its sums (see `segment_sums`).

    Uses the depth-weighted sums: (Δ inverse depth)·d² is the depth residual to first order.
    """
    return math.sqrt(_residual_square_sum(plane, seg_sums, i, _N_SUMS) / seg_sums[i, 0])


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy", inline="always")
def _segment_misfit(
    plane, seg_sums, seg_table, i, x, yv, a, b, grow_factor, rms_factor, tol0, use_pred, limit
):
    """How badly segment i (columns a:b of the row at image y = yv) fits a plane.

    Returns the largest ratio of deviation to tolerance over the two end points of the
    segment's line and its RMS residual (≤ 1: fits; inf: plane behind the camera). With
    ``use_pred`` the plane's own prediction uncertainty widens the tolerances (growing);
    without, only the segment's noise counts (testing a seed against the plane fit to it).
    As soon as a part's ratio exceeds ``limit`` that ratio is returned without the rest (the
    answer is then only known to exceed ``limit``; inf: every part).

    Inlined into its callers in numba IR (``inline="always"``, as `_segment_fits`): called for
    every segment tested, a call of its own took and dropped a reference to each array
    argument (atomic NRT increments and decrements, 5 % of a frame's segmentation).
    """
    n = b - a
    sigma_seg = seg_table[i, 2]
    worst = 0.0
    for k in (a, b - 1):
        inv_plane = plane[0] * x[k] + plane[1] * yv + plane[2]
        if not inv_plane > 0.0:
            return np.inf
        inv_seg = seg_table[i, 0] + seg_table[i, 1] * x[k]
        sigma_pred = _predict_sigma_depth(plane, x[k], yv, inv_plane) if use_pred else 0.0
        tol = grow_factor * math.sqrt(4.0 * sigma_seg * sigma_seg / n + sigma_pred**2) + tol0
        worst = max(worst, _depth_gap(inv_seg, inv_plane) / tol)
        if worst > limit:
            return worst
    mid = (a + b - 1) // 2
    inv_mid = plane[0] * x[mid] + plane[1] * yv + plane[2]
    sigma_pred = _predict_sigma_depth(plane, x[mid], yv, inv_mid) if use_pred else 0.0
    rms_limit = rms_factor * math.sqrt(sigma_seg * sigma_seg + sigma_pred * sigma_pred) + tol0
    return max(worst, _segment_rms(plane, seg_sums, i) / rms_limit)


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy", inline="always")
def _segment_fits(plane, seg_sums, seg_table, i, x, yv, a, b, grow_factor, rms_factor, tol0):
    """Whether segment i lies on a growing plane (see `_segment_misfit`; inlined likewise)."""
    return (
        _segment_misfit(
            plane,
            seg_sums,
            seg_table,
            i,
            x,
            yv,
            a,
            b,
            grow_factor,
            rms_factor,
            tol0,
            _GROWING,
            1.0,
        )
        <= 1.0
    )


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _add_segment(sums, seg_sums, i):
    """Add segment i's moment sums (``seg_sums[i, :10]``) to ``sums``."""
    for k in range(_N_SUMS):
        sums[k] += seg_sums[i, k]


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def segment_sums(inv_depth, x, y, seg_rows, seg_starts, seg_stops):
    """(S, 20) moment sums of every segment for the inverse-depth plane model.

    Columns 0-9: n, Σx, Σy, Σx², Σxy, Σy², Σz, Σxz, Σyz, Σz² (z = inverse depth); columns
    10-19: the same weighted by depth⁴, so that weighted inverse-depth residuals are depth
    residuals to first order.
    """
    n_seg = seg_rows.shape[0]
    out = np.empty((n_seg, 2 * _N_SUMS))
    for i in range(n_seg):
        r = seg_rows[i]
        yv = y[r]
        # Summed in registers from 0 in pixel order (the same sums as adding into the row).
        n = sx = sy = sxx = sxy = syy = sz = sxz = syz = szz = 0.0
        w0 = wx = wy = wxx = wxy = wyy = wz = wxz = wyz = wzz = 0.0
        for c in range(seg_starts[i], seg_stops[i]):
            z = inv_depth[r, c]
            xv = x[c]
            n += 1.0
            sx += xv
            sy += yv
            sxx += xv * xv
            sxy += xv * yv
            syy += yv * yv
            sz += z
            sxz += xv * z
            syz += yv * z
            szz += z * z
            w = 1.0 / (z * z * z * z)
            w0 += w
            wx += w * xv
            wy += w * yv
            wxx += w * xv * xv
            wxy += w * xv * yv
            wyy += w * yv * yv
            wz += w * z
            wxz += w * xv * z
            wyz += w * yv * z
            wzz += w * z * z
        for k, value in enumerate(
            (
                n,
                sx,
                sy,
                sxx,
                sxy,
                syy,
                sz,
                sxz,
                syz,
                szz,
                w0,
                wx,
                wy,
                wxx,
                wxy,
                wyy,
                wz,
                wxz,
                wyz,
                wzz,
            )
        ):
            out[i, k] = value
    return out


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _best_seed(s, segments, plane_of, limits, work):
    """Best seed triple containing segment s among free segments.

    Tries rows (r, r+1, r+2), (r-1, r, r+1), (r-2, r-1, r), in each picking row by row away
    from s the longest free segment overlapping the previous one. Writes the best triple to
    ``members`` and returns its misfit (≤ 1: valid seed; inf: none).

    Every segment picked beside s is written to ``tried[s]`` ((S, 9) int64, -1 for none;
    entry ``3·i + k`` for row k of the i-th triple tried): while s and these stay free the
    result cannot change (a pick is the longest free overlapping segment, and taking others
    only removes candidates that lost to it, or that a broken triple never had), so
    `grow_planes` can reuse it instead of scoring again.

    Args:
        s: The segment.
        segments: ``(seg_sums, x, y, seg_rows, seg_starts, seg_stops, seg_table, row_first)``,
            as `grow_planes` has them (``row_first``: `_row_index`).
        plane_of: (S,) plane of every segment so far (-1: free).
        limits: ``(grow_factor, rms_factor, tol0, seed_min_pixels)`` of `grow_planes`.
        work: ``(members, sums, plane, chosen, tried)``: (3,) the best triple (written),
            (`_N_SUMS`,) and (13,) scratch for the fit, (3,) scratch for a triple, (S, 9)
            the segments picked beside each seed (row s written).
    """
    seg_sums, x, y, seg_rows, seg_starts, seg_stops, seg_table, row_first = segments
    grow_factor, rms_factor, tol0, seed_min_pixels = limits
    members, sums, plane, chosen, tried = work
    for k in range(9):
        tried[s, k] = -1
    height = row_first.shape[0] - 1
    lengths_s = seg_stops[s] - seg_starts[s]
    best_score = np.inf
    if lengths_s < seed_min_pixels:
        return best_score
    r = seg_rows[s]
    for offset in (0, -1, -2):
        if r + offset < 0 or r + offset + 2 >= height:
            continue
        for k in range(3):  # element-wise: a slice is a view, made at every call
            chosen[k] = -1
        chosen[-offset] = s
        ok = True
        for direction in (1, -1):
            k = -offset + direction
            while 0 <= k <= 2:
                prev = chosen[k - direction]
                pick = -1
                pick_len = 0
                rr = r + offset + k
                for t in range(row_first[rr], row_first[rr + 1]):
                    length = seg_stops[t] - seg_starts[t]
                    if plane_of[t] >= 0 or length < seed_min_pixels or length <= pick_len:
                        continue
                    if _overlap(
                        seg_starts[prev], seg_stops[prev], seg_starts[t], seg_stops[t], _NO_GAP
                    ):
                        pick = t
                        pick_len = length
                if pick < 0:
                    ok = False
                    break
                chosen[k] = pick
                tried[s, -3 * offset + k] = pick
                k += direction
            if not ok:
                break
        if not ok:
            continue
        for k in range(_N_SUMS):
            sums[k] = 0.0
        for k in range(3):
            _add_segment(sums, seg_sums, chosen[k])
        if not _solve_plane(sums, plane):
            continue
        # A triple only counts if it fits (misfit ≤ 1) and beats the best so far (strictly):
        # its members' misfits stop at the first above that.
        limit = min(best_score, 1.0)
        score = 0.0
        for k in range(3):
            t = chosen[k]
            score = max(
                score,
                _segment_misfit(
                    plane,
                    seg_sums,
                    seg_table,
                    t,
                    x,
                    y[seg_rows[t]],
                    seg_starts[t],
                    seg_stops[t],
                    grow_factor,
                    rms_factor,
                    tol0,
                    _SEED_TEST,
                    limit,
                ),
            )
            if score > limit:
                break
        if score < best_score and score <= 1.0:
            best_score = score
            for k in range(3):  # element-wise: a slice copy compiles a shape check (~1.5 s)
                members[k] = chosen[k]
    return best_score


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def grow_planes(
    inv_depth,
    x,
    y,
    seg_rows,
    seg_starts,
    seg_stops,
    seg_table,
    seg_sums,
    grow_factor,
    rms_factor,
    tolerance_floor_m,
    seed_min_pixels,
):
    """Region growing of planes over row segments.

    Every segment's best seed triple is scored first (misfit to the plane through it, see
    `_segment_misfit`); planes are then seeded best-first, so seeds in the interior of surfaces
    win over seeds straddling an edge (e.g. tread, tread, riser of a low step), and grow
    breadth-first into touching segments that fit the current plane, refit after each one.

    Args:
        inv_depth: (H, W) inverse depth [1/m].
        x: (W,) normalised image x of the columns.
        y: (H,) normalised image y of the rows.
        seg_rows: (S,) row of each segment (output of `split_rows`).
        seg_starts: (S,) first column of each segment.
        seg_stops: (S,) column after the last of each segment.
        seg_table: (S, 3) line parameters and mean sigma of each segment.
        seg_sums: (S, 20) moment sums of each segment (`segment_sums`).
        grow_factor: end points must agree within this many sigma.
        rms_factor: the RMS depth residual must be within this many sigma.
        tolerance_floor_m: constant added to every tolerance [m].
        seed_min_pixels: minimum length of each seed segment.

    Returns:
        (S,) int64 plane index of every segment, -1 for none; planes numbered in creation order.
    """
    height = inv_depth.shape[0]
    n_seg = seg_rows.shape[0]
    plane_of = np.full(n_seg, -1, np.int64)
    if n_seg == 0:
        return plane_of
    row_first = _row_index(seg_rows, height)
    sums = np.zeros(_N_SUMS)
    plane = np.zeros(13)
    members = np.full(3, -1, np.int64)
    chosen = np.full(3, -1, np.int64)  # `_best_seed`'s work space
    tried = np.full((n_seg, 9), -1, np.int64)
    seed_members = np.full((n_seg, 3), -1, np.int64)
    scores = np.full(n_seg, np.inf)
    segments = (seg_sums, x, y, seg_rows, seg_starts, seg_stops, seg_table, row_first)
    limits = (grow_factor, rms_factor, tolerance_floor_m, seed_min_pixels)
    work = (members, sums, plane, chosen, tried)
    for s in range(n_seg):
        scores[s] = _best_seed(s, segments, plane_of, limits, work)
        for k in range(3):
            seed_members[s, k] = members[k]
    order = _stable_order(scores)
    queue = np.empty(n_seg, np.int64)
    n_planes = 0
    for s in order:
        if scores[s] > 1.0:
            break
        if plane_of[s] >= 0:
            continue
        # Scored again only if a plane took one of the segments its triples picked.
        stale = False
        for k in range(9):
            t = tried[s, k]
            if t >= 0 and plane_of[t] >= 0:
                stale = True
                break
        if not stale:
            score = scores[s]
            for k in range(3):
                members[k] = seed_members[s, k]
        else:
            score = _best_seed(s, segments, plane_of, limits, work)
        if score > 1.0:
            continue
        label = n_planes
        n_planes += 1
        head = 0
        tail = 0
        for k in range(_N_SUMS):
            sums[k] = 0.0
        for k in range(3):
            t = members[k]
            plane_of[t] = label
            queue[tail] = t
            tail += 1
            _add_segment(sums, seg_sums, t)
        _solve_plane(sums, plane)
        while head < tail:
            q = queue[head]
            head += 1
            rq = seg_rows[q]
            for rr in (rq - 1, rq, rq + 1):
                if rr < 0 or rr >= height:
                    continue
                gap = 1 if rr == rq else 0
                for t in range(row_first[rr], row_first[rr + 1]):
                    if plane_of[t] >= 0:
                        continue
                    if not _overlap(seg_starts[q], seg_stops[q], seg_starts[t], seg_stops[t], gap):
                        continue
                    if _segment_fits(
                        plane,
                        seg_sums,
                        seg_table,
                        t,
                        x,
                        y[rr],
                        seg_starts[t],
                        seg_stops[t],
                        grow_factor,
                        rms_factor,
                        tolerance_floor_m,
                    ):
                        plane_of[t] = label
                        queue[tail] = t
                        tail += 1
                        _add_segment(sums, seg_sums, t)
                        _solve_plane(sums, plane)
    return plane_of


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def reassign_segments(
    inv_depth,
    x,
    y,
    seg_rows,
    seg_starts,
    seg_stops,
    seg_table,
    seg_sums,
    plane_of,
    grow_factor,
    rms_factor,
    tolerance_floor_m,
    passes,
):
    """Move segments to a neighbouring plane that fits them clearly better, then refit.

    Region growing is greedy: a plane grown early (e.g. a tilted one seeded across a step
    edge) may hold segments that belong to a neighbour grown later. Each pass compares every
    assigned segment with the planes of the segments touching it (rows above, below, same
    row) and moves it when another plane accepts it and its RMS residual there is below
    0.8× the current one. ``plane_of`` is updated in place.

    Returns:
        How many segments moved in total.
    """
    height = inv_depth.shape[0]
    n_seg = seg_rows.shape[0]
    n_planes = 0
    for i in range(n_seg):
        n_planes = max(n_planes, plane_of[i] + 1)
    if n_planes == 0:
        return 0
    row_first = _row_index(seg_rows, height)
    moved_total = 0
    sums = np.zeros((n_planes, _N_SUMS))
    planes = np.full((n_planes, 13), np.nan)
    valid = np.zeros(n_planes, np.bool_)
    for _ in range(passes):
        sums[:] = 0.0
        for i in range(n_seg):
            if plane_of[i] >= 0:
                r = seg_rows[i]
                _add_segment(sums[plane_of[i]], seg_sums, i)
        for p in range(n_planes):
            valid[p] = _solve_plane(sums[p], planes[p])
        before = plane_of.copy()
        moved = 0
        for i in range(n_seg):
            own = before[i]
            if own < 0 or not valid[own]:
                continue
            r = seg_rows[i]
            a = seg_starts[i]
            b = seg_stops[i]
            best_rms = 0.8 * _segment_rms(planes[own], seg_sums, i)
            best = own
            for rr in (r - 1, r, r + 1):
                if rr < 0 or rr >= height:
                    continue
                gap = 1 if rr == r else 0
                for t in range(row_first[rr], row_first[rr + 1]):
                    q = before[t]
                    if q < 0 or q in (own, best) or not valid[q]:
                        continue
                    if not _overlap(a, b, seg_starts[t], seg_stops[t], gap):
                        continue
                    rms_q = _segment_rms(planes[q], seg_sums, i)
                    if rms_q < best_rms and _segment_fits(
                        planes[q],
                        seg_sums,
                        seg_table,
                        i,
                        x,
                        y[r],
                        a,
                        b,
                        grow_factor,
                        rms_factor,
                        tolerance_floor_m,
                    ):
                        best = q
                        best_rms = rms_q
            if best != own:
                plane_of[i] = best
                moved += 1
        moved_total += moved
        if moved == 0:
            break
    return moved_total
