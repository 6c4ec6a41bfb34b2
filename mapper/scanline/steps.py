"""Level regions split along a step their rows could not see (beyond Gutmann et al.).

Level regions grow over row segments whose mean heights agree (`mapper.scanline.levels`); a
row is split where its heights step by more than the step test's standard error. Under a
stereo matcher's noise (σ_z about 10–20 mm a pixel at 1–1.5 m, errors correlated over its
window) neither test sees a 15–20 mm step: the rows run on over a low tread's side edge, and
one region takes the ground and the tread beside it (`down_landing_turn` stereo seed 1, frames
648–692: the frames' largest plane holds 450–600 pixels of step_1, 20 mm high, 0.9–1.2 m away,
whose raw stereo points lie at +13…+20 mm through the true camera pose, and the ground's level
region takes them in too: its one height puts step_1 at the ground's in the map, whose step_1
cell went 20.0 → 2.4 mm at frame 604).

What no row shows, the region's pixels together do: fitted by a plane with a step,
``z = a + b·x + c·y + Δ·[s > s₀]`` (``s`` the pixel's position along a direction in the
horizontal plane, ``s₀`` a split across it), the step's t-statistic
``|Δ| / sqrt(τ·σ²·(BᵀB)⁻¹_ΔΔ)`` (σ² the residual variance of that model, τ the noise's
correlation factor) is large where two levels were joined, and small on one level, whatever
its tilt (a tilt error is the plane's ``b, c``, not ``Δ``). `best_step` tries
`SPLIT_DIRECTIONS` directions and `SPLIT_BINS` − 1 splits along each;
:func:`split_stepped_levels` splits a region whose best ``t`` exceeds the threshold with
``|Δ|`` at least `MIN_STEP_M`, and tests each part again. Measured on raw stereo points:
joined ground and step_1 score t 9–11 (``Δ`` 12–18 mm), every region of the `flat_floor` and
`room` stereo recordings at most 6.4 (`SegmentationParams.floor_step_split_t` has these and the
stereo suites' figures with it: no default).

The split line only finds the step: a tread's corner or a side edge between two test
directions is no straight cut of the region. Its pixels are parted by the step's own model
(`_upper_part`): a pixel whose window (`SMOOTHING_RADIUS_PX`) has a mean residual about one
level's plane beyond half the step is on the other level; the two levels are fitted to that
parting and the pixels parted again (`PARTING_ROUNDS`). The level with fewer pixels leaves:
its pixels whose window is sure of it (`CONFIDENCE_SIGMAS`), in 4-connected parts of at least
``min_pixels`` pixels (a noise blob is no tread), take a new region id — unless their median
``σ_z`` exceeds `NOISE_PER_STEP` times the step (far away, 3–4 m on `talos_course`'s stereo
seed 6, a region of several levels blended by the noise was parted into pieces whose levels
were no surface's, and the z-match followed them 20–60 mm off). The row segments are then cut
where their pixels' region changes (`cut_segments`: the segment fit of `floor_segment_fit` and
the levels of `level_heights`); both parts are measured and judged as every region is.
"""

from __future__ import annotations

import math

import numba
import numpy as np

SPLIT_DIRECTIONS = 8
"""Directions of the step tried, ``k·180°/8`` in the tilt-corrected frame's horizontal plane:
an edge between two test directions is at most 11.25° off one of them, which blurs a split of
a 0.5 m edge by 0.1 m at its ends."""

NOISE_PER_STEP = 1.0
"""The most median ``σ_z`` of the pixels that would leave, per metre of the step: a level
parted from pixels noisier than its step is no surface's. With 2 (a 5 × 5 window's mean has a
std of about ``0.35·σ_z`` at τ 3, so half the step is still 0.7 of it) `talos_course`'s
stereo seed 6 parted far regions at 3–4 m (σ_z about 50 mm, steps of 55–65 mm) into levels the
z-match then followed 20–60 mm off: every Table I row 34–36 mm low, 2603 unsafe cells (28
without the split); with 1: 58. Replays of the `down_landing_turn` and `down_shallow_steps`
stereo recordings, seeds 1–8, unsafe cells in all: 945 without the split, 860 with 2, 835
with 1."""

MIN_STEP_M = 0.01
"""The least height of a step that splits a region [m]: twice the growing's height tolerance
(`SegmentationParams.floor_height_tolerance_m`, 5 mm). Over a large region a few millimetres of
the matcher's range-dependent bias score a large t; the lowest steps of the scenes, 15–20 mm,
measure 12–18 mm joined (their edges blended)."""

SMOOTHING_RADIUS_PX = 2
"""Half-width of the window whose mean residual puts a pixel on one level or the other [px]:
5 × 5 pixels, whose mean under stereo noise (σ_z 11–15 mm, τ 3) has a std of about 5 mm, a
quarter of a 20 mm step; the boundary blurs by about the radius."""

CONFIDENCE_SIGMAS = 1.0
"""How far beyond half the step a window's mean residual must lie to move its pixel, in the
mean's standard errors (its pixels' ``σ_z``, widened by the correlation factor): a window the
noise leaves undecided keeps its pixel where it was (far ground, σ_z 30–40 mm a pixel at 2.5 m,
would otherwise join a tread in blobs as large as the tread)."""

PARTING_ROUNDS = 3
"""How often the two levels are fitted to the pixels' parting and the pixels parted again: the
first parting comes from the split line's fit, whose planes a corner or a slanted edge bends."""

SPLIT_BINS = 16
"""Equal bins of a region's extent along a direction; the split is tried between each two (15
places, each side keeping at least ``min_pixels``): one pass over the pixels a direction, no
sort (sorting them for quantile splits took the stereo frames' segmentation from 1.7 to 5.0 ms,
`bench/bench_segmentation.py`)."""


@numba.njit(cache=True, inline="always")
def plane_inverse(n, sx, sy, sxx, sxy, syy):
    """The inverse of a plane fit's normal matrix by cofactors.

    ``A = [[n, sx, sy], [sx, sxx, sxy], [sy, sxy, syy]]`` (sums over the points of 1, x, y and
    their products). Returns ``(det, (i00, i01, i02, i11, i12, i22))``, the upper triangle of
    ``A⁻¹``; ``det <= 0`` (the points lie on a line): no inverse (zeros).
    """
    c00 = sxx * syy - sxy * sxy
    c01 = sy * sxy - sx * syy
    c02 = sx * sxy - sy * sxx
    c11 = n * syy - sy * sy
    c12 = sx * sy - n * sxy
    c22 = n * sxx - sx * sx
    det = n * c00 + sx * c01 + sy * c02
    if not det > 0.0:
        return det, (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    return det, (c00 / det, c01 / det, c02 / det, c11 / det, c12 / det, c22 / det)


@numba.njit(cache=True, inline="always")
def plane_step(inverse, beta, moments, upper, n, correlation):
    """The step ``Δ`` of the model ``z = a + b·x + c·y + Δ·[s > s₀]`` and its t-statistic.

    Solved through the plane's normal equations (``inverse``: `plane_inverse`; ``beta`` =
    (a0, b0, c0) the plane's fit) and the Schur complement of the step's column: with ``u`` its
    products with ``[1, x, y]`` (``upper`` = (u0, u1, u2, Σ_{s>s₀} z)), ``w = A⁻¹u``,
    ``Δ = (Σ_{s>s₀} z − u·β) / (u0 − u·w)``, ``(BᵀB)⁻¹_ΔΔ = 1 / (u0 − u·w)``; ``moments`` =
    (Σz, Σxz, Σyz, Σz²) of the points (x, y, z about their means), ``n`` their count,
    ``correlation`` τ (the variance's factor).

    Returns:
        (Δ, t, (w0, w1, w2)); Δ and t NaN when the complement is not positive (the split's
        column depends on the plane's). The plane with the step is ``β − w·Δ``.
    """
    i00, i01, i02, i11, i12, i22 = inverse
    a0, b0, c0 = beta
    sz, sxz, syz, szz = moments
    u0, u1, u2, upper_z = upper
    w0 = i00 * u0 + i01 * u1 + i02 * u2
    w1 = i01 * u0 + i11 * u1 + i12 * u2
    w2 = i02 * u0 + i12 * u1 + i22 * u2
    schur = u0 - (u0 * w0 + u1 * w1 + u2 * w2)
    if not schur > 0.0:
        return np.nan, np.nan, (w0, w1, w2)
    delta = (upper_z - (u0 * a0 + u1 * b0 + u2 * c0)) / schur
    explained = (
        (a0 - w0 * delta) * sz + (b0 - w1 * delta) * sxz + (c0 - w2 * delta) * syz + delta * upper_z
    )
    variance = max(szz - explained, 0.0) / (n - 4) * correlation / schur
    return delta, abs(delta) / math.sqrt(variance), (w0, w1, w2)


@numba.njit(cache=True, inline="always")
def sums_beyond(runs, beyond):
    """Each split's step-column sums from per-run sums: ``beyond[j]`` = Σ of ``runs[j:]``.

    ``runs`` (R, 4): per run of points between two splits (in order along the split
    direction) their count, Σx, Σy, Σz; ``beyond`` (R + 1, 4) is set to the sums over the runs
    from ``j`` on, added from the top (``beyond[R]`` = 0): the ``upper`` of `plane_step` for a
    split before run ``j``.
    """
    last = runs.shape[0]
    beyond[last] = 0.0
    for j in range(last - 1, -1, -1):
        for c in range(4):
            beyond[j, c] = beyond[j + 1, c] + runs[j, c]


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def best_step(x, y, z, bins, directions, correlation, min_step_m, min_side):
    """The best split of one region's pixels by a plane with a step (module doc).

    Args:
        x: (n,) the pixels' x in the tilt-corrected frame [m].
        y: (n,) their y [m].
        z: (n,) their heights [m].
        bins: how many equal bins the pixels' extent along a direction is cut into; the splits
            lie between them (`SPLIT_BINS`).
        directions: how many directions over 180°.
        correlation: the noise's correlation factor τ (≥ 1).
        min_step_m: the least ``|Δ|`` a split may have [m].
        min_side: the fewest pixels either side may keep.

    Returns:
        (t, (Δ [m], h, b, c)): the step of the pixels beyond the split over the plane
        ``z = h + b·x + c·y`` of those before it (``h`` at the pixels' mean x, y); t = 0 when no
        split qualifies.
    """
    n = x.size
    best_t = 0.0
    best = (0.0, 0.0, 0.0, 0.0)
    if n < max(2 * min_side, 8):
        return best_t, best
    mx = x.mean()
    my = y.mean()
    mz = z.mean()
    xc = x - mx
    yc = y - my
    zc = z - mz
    sx = xc.sum()
    sy = yc.sum()
    sz = zc.sum()
    sxx = (xc * xc).sum()
    sxy = (xc * yc).sum()
    syy = (yc * yc).sum()
    sxz = (xc * zc).sum()
    syz = (yc * zc).sum()
    szz = (zc * zc).sum()
    det, inverse = plane_inverse(n, sx, sy, sxx, sxy, syy)
    if not det > 0.0:
        return best_t, best  # the pixels lie on a line
    i00, i01, i02, i11, i12, i22 = inverse
    beta = (
        i00 * sz + i01 * sxz + i02 * syz,
        i01 * sz + i11 * sxz + i12 * syz,
        i02 * sz + i12 * sxz + i22 * syz,
    )
    moments = (sz, sxz, syz, szz)
    runs = np.empty((bins, 4))  # per bin: pixels, Σx, Σy, Σz
    beyond = np.empty((bins + 1, 4))
    for k in range(directions):
        angle = math.pi * k / directions
        cos_a = math.cos(angle)
        sin_a = math.sin(angle)
        low = np.inf
        high = -np.inf
        for i in range(n):
            v = xc[i] * cos_a + yc[i] * sin_a
            low = min(low, v)
            high = max(high, v)
        if not high > low:
            continue
        runs[:] = 0.0
        scale = bins / (high - low)
        for i in range(n):
            b = min(int((xc[i] * cos_a + yc[i] * sin_a - low) * scale), bins - 1)
            runs[b, 0] += 1.0
            runs[b, 1] += xc[i]
            runs[b, 2] += yc[i]
            runs[b, 3] += zc[i]
        # Splits between bins: the step column's sums are those of the bins beyond.
        sums_beyond(runs, beyond)
        for b in range(bins - 1, 0, -1):
            m = beyond[b, 0]
            if m < min_side or n - m < min_side:
                continue
            upper = (m, beyond[b, 1], beyond[b, 2], beyond[b, 3])
            delta, t, (w0, w1, w2) = plane_step(inverse, beta, moments, upper, n, correlation)
            if not math.isfinite(t) or abs(delta) < min_step_m:
                continue  # no complement or no variance left; or too low a step
            if t > best_t:
                best_t = t
                a0, b0, c0 = beta
                best = (delta, mz + a0 - w0 * delta, b0 - w1 * delta, c0 - w2 * delta)
    return best_t, best


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _solve4(a, b):
    """``a⁻¹·b`` of a symmetric positive (4, 4) ``a`` by Gaussian elimination (NaN: singular)."""
    m = a.copy()
    v = b.copy()
    for k in range(4):
        if not abs(m[k, k]) > 1e-12:
            return np.full(4, np.nan)
        for i in range(k + 1, 4):
            factor = m[i, k] / m[k, k]
            for j in range(k, 4):
                m[i, j] -= factor * m[k, j]
            v[i] -= factor * v[k]
    out = np.zeros(4)
    for i in range(3, -1, -1):
        total = v[i]
        for j in range(i + 1, 4):
            total -= m[i, j] * out[j]
        out[i] = total / m[i, i]
    return out


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _two_level_fit(labels, points, sigma_z, f, upper, mx, my, box):
    """Least squares ``z = h + b·x + c·y + Δ·u`` over region ``f`` (``u``: ``upper``).

    Each pixel is weighted by ``1/σ_z²``; the region lies within ``box`` (rows ``r0 … r1 − 1``,
    columns ``c0 … c1 − 1``).
    """
    r0, r1, c0, c1 = box
    a = np.zeros((4, 4))
    rhs = np.zeros(4)
    row = np.zeros(4)
    for r in range(r0, r1):
        for cc in range(c0, c1):
            if labels[r, cc] != f or points[r, cc, 2] != points[r, cc, 2]:
                continue
            row[0] = 1.0
            row[1] = points[r, cc, 0] - mx
            row[2] = points[r, cc, 1] - my
            row[3] = 1.0 if upper[r, cc] else 0.0
            weight = 1.0 / (sigma_z[r, cc] * sigma_z[r, cc])
            for i in range(4):
                rhs[i] += weight * row[i] * points[r, cc, 2]
                for j in range(4):
                    a[i, j] += weight * row[i] * row[j]
    return _solve4(a, rhs)


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _upper_part(
    labels,
    points,
    sigma_z,
    f,
    plane,
    delta,
    mx,
    my,
    radius,
    min_pixels,
    rounds,
    correlation,
    confidence,
    box,
):
    """(H, W) bool: the pixels of region ``f`` that leave it for the step's smaller level.

    A pixel lies on the other level when the mean residual of the region's pixels within
    ``radius`` of it (about the plane ``plane`` = (h, b, c) at ``mx, my`` of one level) lies
    beyond half the step ``delta``; the plane and the step are then fitted to that parting
    (pixels weighted by ``1/σ_z²``) and the pixels parted again, ``rounds`` times. Of the
    level with fewer pixels, those whose window's mean lies beyond the half step by
    ``confidence`` of its standard errors, in 4-connected parts of at least ``min_pixels``;
    and the last parting's step [m]. The region lies within ``box`` (`_two_level_fit`).
    """
    height, width = labels.shape
    r0, r1, c0, c1 = box
    h, b, c = plane
    residual = np.full((height, width), np.nan)
    member = np.zeros((height, width), dtype=np.bool_)
    mean = np.full((height, width), np.nan)
    spread = np.zeros((height, width))
    rows = r1 - r0
    cols = c1 - c0
    sum_v = np.zeros((rows + 1, cols + 1))
    sum_n = np.zeros((rows + 1, cols + 1))
    sum_s = np.zeros((rows + 1, cols + 1))
    half = 0.0
    for round_ in range(rounds + 1):
        if round_ > 0:
            fit = _two_level_fit(labels, points, sigma_z, f, member, mx, my, box)
            if fit[0] != fit[0] or abs(fit[3]) < 1e-9:
                break
            h, b, c, delta = fit[0], fit[1], fit[2], fit[3]
        for r in range(r0, r1):
            for cc in range(c0, c1):
                if labels[r, cc] == f and points[r, cc, 2] == points[r, cc, 2]:
                    x = points[r, cc, 0] - mx
                    y = points[r, cc, 1] - my
                    residual[r, cc] = points[r, cc, 2] - (h + b * x + c * y)
        half = 0.5 * abs(delta)
        sign = 1.0 if delta > 0.0 else -1.0
        # Window sums from summed-area tables over the box: the residuals' (this round's), and,
        # the first round, the pixels' count and their σ_z² (the same every round).
        for r in range(rows):
            for cc in range(cols):
                v = residual[r0 + r, c0 + cc]
                finite = v == v
                sum_v[r + 1, cc + 1] = (
                    sum_v[r, cc + 1] + sum_v[r + 1, cc] - sum_v[r, cc] + (v if finite else 0.0)
                )
                if round_ == 0:
                    s2 = sigma_z[r0 + r, c0 + cc] ** 2 if finite else 0.0
                    sum_n[r + 1, cc + 1] = (
                        sum_n[r, cc + 1]
                        + sum_n[r + 1, cc]
                        - sum_n[r, cc]
                        + (1.0 if finite else 0.0)
                    )
                    sum_s[r + 1, cc + 1] = sum_s[r, cc + 1] + sum_s[r + 1, cc] - sum_s[r, cc] + s2
        others = 0
        pixels = 0
        for r in range(r0, r1):
            for cc in range(c0, c1):
                member[r, cc] = False
                mean[r, cc] = np.nan
                if residual[r, cc] != residual[r, cc]:
                    continue
                top = max(r - radius, r0) - r0
                bottom = min(r + radius + 1, r1) - r0
                left = max(cc - radius, c0) - c0
                right = min(cc + radius + 1, c1) - c0
                total = sum_v[bottom, right] - sum_v[top, right] - sum_v[bottom, left]
                total += sum_v[top, left]
                count = sum_n[bottom, right] - sum_n[top, right] - sum_n[bottom, left]
                count += sum_n[top, left]
                noise = sum_s[bottom, right] - sum_s[top, right] - sum_s[bottom, left]
                noise += sum_s[top, left]
                # Along the step, from the plane's level (0) toward the other level (|Δ|).
                mean[r, cc] = sign * total / count
                spread[r, cc] = math.sqrt(correlation * max(noise, 0.0)) / count
                member[r, cc] = mean[r, cc] > half
                others += member[r, cc]
                pixels += 1
    # The level with fewer pixels moves: its pixels whose window is sure of it.
    minority_other = 2 * others <= pixels
    candidate = np.zeros((height, width), dtype=np.bool_)
    for r in range(r0, r1):
        for cc in range(c0, c1):
            m = mean[r, cc]
            if m != m:
                continue
            if minority_other:
                candidate[r, cc] = m > half + confidence * spread[r, cc]
            else:
                candidate[r, cc] = m < half - confidence * spread[r, cc]
    # Its 4-connected parts of at least min_pixels pixels (breadth-first).
    upper = np.zeros((height, width), dtype=np.bool_)
    seen = np.zeros((height, width), dtype=np.bool_)
    stack_r = np.empty(height * width, dtype=np.int64)
    stack_c = np.empty(height * width, dtype=np.int64)
    part_r = np.empty(height * width, dtype=np.int64)
    part_c = np.empty(height * width, dtype=np.int64)
    for first_r in range(r0, r1):
        for first_c in range(c0, c1):
            if not candidate[first_r, first_c] or seen[first_r, first_c]:
                continue
            seen[first_r, first_c] = True
            stack_r[0] = first_r
            stack_c[0] = first_c
            top = 1
            size = 0
            while top > 0:
                top -= 1
                r = stack_r[top]
                cc = stack_c[top]
                part_r[size] = r
                part_c[size] = cc
                size += 1
                for dr, dc in ((-1, 0), (1, 0), (0, -1), (0, 1)):
                    rr = r + dr
                    c2 = cc + dc
                    inside = 0 <= rr < height and 0 <= c2 < width
                    if inside and candidate[rr, c2] and not seen[rr, c2]:
                        seen[rr, c2] = True
                        stack_r[top] = rr
                        stack_c[top] = c2
                        top += 1
            if size >= min_pixels:
                for i in range(size):
                    upper[part_r[i], part_c[i]] = True
    return upper, delta


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def split_stepped_levels(
    labels,
    grown,
    points,
    sigma_z,
    n_floors,
    bins,
    directions,
    min_t,
    min_step_m,
    min_pixels,
    correlation,
    confidence,
):
    """Split every level region that is two levels joined over a step (module doc); in place.

    Args:
        labels: (H, W) int64 level region of each pixel (-1 none, -2 no measurement); the
            pixels on the step's other level take the new region's id.
        grown: (H, W) int64 the regions' grown pixels (before the pixel fill), relabelled alike
            (not ``labels`` itself).
        points: (H, W, 3) the pixels' points in the tilt-corrected frame [m] (NaN: none).
        sigma_z: (H, W) their noise along z [m].
        n_floors: how many regions there are.
        bins: the split bins (`SPLIT_BINS`).
        directions: directions tried (`SPLIT_DIRECTIONS`).
        min_t: the step's t-statistic a split needs (> 0).
        min_step_m: the least ``|Δ|`` of a split [m].
        min_pixels: regions with fewer than twice this many measured pixels are not tested,
            and no part keeps fewer.
        correlation: the noise's correlation factor τ (≥ 1).
        confidence: `CONFIDENCE_SIGMAS`.

    Returns:
        The number of regions after the splits (at most twice ``n_floors``).
    """
    height, width = labels.shape
    limit = 2 * n_floors
    total = n_floors
    queue = np.empty(3 * n_floors + 1, dtype=np.int64)
    for f in range(n_floors):
        queue[f] = f
    head = 0
    tail = n_floors
    xs = np.empty(height * width)
    ys = np.empty(height * width)
    zs = np.empty(height * width)
    noise = np.empty(height * width)
    # Each region's bounding box (rows r0 … r1 − 1, columns c0 … c1 − 1); a part keeps its
    # region's.
    boxes = np.empty((limit, 4), dtype=np.int64)
    boxes[:, 0] = height
    boxes[:, 1] = 0
    boxes[:, 2] = width
    boxes[:, 3] = 0
    for r in range(height):
        for c in range(width):
            f = labels[r, c]
            if 0 <= f < n_floors:
                boxes[f, 0] = min(boxes[f, 0], r)
                boxes[f, 1] = max(boxes[f, 1], r + 1)
                boxes[f, 2] = min(boxes[f, 2], c)
                boxes[f, 3] = max(boxes[f, 3], c + 1)
    while head < tail and total < limit:
        f = queue[head]
        head += 1
        r0, r1, c0, c1 = boxes[f, 0], boxes[f, 1], boxes[f, 2], boxes[f, 3]
        n = 0
        for r in range(r0, r1):
            for c in range(c0, c1):
                if labels[r, c] == f and points[r, c, 2] == points[r, c, 2]:
                    xs[n] = points[r, c, 0]
                    ys[n] = points[r, c, 1]
                    zs[n] = points[r, c, 2]
                    n += 1
        if n < 2 * min_pixels:
            continue
        t, fit = best_step(
            xs[:n], ys[:n], zs[:n], bins, directions, correlation, min_step_m, min_pixels
        )
        if not t > min_t:
            continue
        delta, h, b, c = fit
        upper, step_m = _upper_part(
            labels,
            points,
            sigma_z,
            f,
            (h, b, c),
            delta,
            xs[:n].mean(),
            ys[:n].mean(),
            SMOOTHING_RADIUS_PX,
            min_pixels,
            PARTING_ROUNDS,
            correlation,
            confidence,
            (r0, r1, c0, c1),
        )
        moved = 0
        for r in range(r0, r1):
            for cc in range(c0, c1):
                if upper[r, cc]:
                    noise[moved] = sigma_z[r, cc]
                    moved += 1
        if moved < min_pixels or n - moved < min_pixels:
            continue
        if np.median(noise[:moved]) > NOISE_PER_STEP * abs(step_m):
            continue  # the step is lost in its pixels' noise: their level is no tread's
        g = total
        total += 1
        boxes[g] = boxes[f]
        for r in range(r0, r1):
            for cc in range(c0, c1):
                if upper[r, cc]:
                    labels[r, cc] = g
                    if grown[r, cc] == f:
                        grown[r, cc] = g
        queue[tail] = f  # each part is tested again
        queue[tail + 1] = g
        tail += 2
    return total


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _cut_at(grown, r, c):
    """Whether a segment is cut before column ``c`` of row ``r``: two regions meet there."""
    a = grown[r, c - 1]
    b = grown[r, c]
    return a >= 0 and b >= 0 and a != b


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def cut_segments(grown, seg_rows, seg_starts, seg_stops, floor_of_segment):
    """The row segments cut where their grown pixels' region changes (after the splits).

    A segment of a region keeps its pixels in order; where `split_stepped_levels` gave part of
    them another region's id it is cut into runs of one id each, every run a segment of its
    region. Segments of no region, and segments no split touched, stay as they are.

    Returns:
        (rows, starts, stops, floor_of_segment) of the segments after the cuts.
    """
    n_seg = seg_rows.shape[0]
    count = n_seg
    for i in range(n_seg):
        if floor_of_segment[i] >= 0:
            for c in range(seg_starts[i] + 1, seg_stops[i]):
                count += _cut_at(grown, seg_rows[i], c)
    rows = np.empty(count, dtype=seg_rows.dtype)
    starts = np.empty(count, dtype=seg_starts.dtype)
    stops = np.empty(count, dtype=seg_stops.dtype)
    floors = np.empty(count, dtype=floor_of_segment.dtype)
    k = 0
    for i in range(n_seg):
        r = seg_rows[i]
        start = seg_starts[i]
        floor = floor_of_segment[i]
        if floor >= 0:
            for c in range(seg_starts[i] + 1, seg_stops[i]):
                if _cut_at(grown, r, c):
                    rows[k] = r
                    starts[k] = start
                    stops[k] = c
                    floors[k] = grown[r, c - 1]
                    k += 1
                    start = c
            if grown[r, start] >= 0:
                floor = grown[r, start]
        rows[k] = r
        starts[k] = start
        stops[k] = seg_stops[i]
        floors[k] = floor
        k += 1
    return rows, starts, stops, floors
