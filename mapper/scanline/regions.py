"""What the planes and the level regions share: row segments' neighbours and labelled pixels.

Both grow regions over the row segments of `mapper.scanline.rows` (planes in inverse depth,
`mapper.scanline.planes`; level regions in height, `mapper.scanline.levels`) and label the image
from them (image frame: (H, W) int64 labels, the region's id, -1 none, -2 no measurement):

- `_row_index`, `_overlap`: which segments touch (rows above, below, same row);
- `_stable_order`: the order seeds are taken in (numpy's stable argsort);
- `segment_labels`: the labels of the segments' pixels;
- `fill_pixels`: leftover pixels next to a plane (or a level floor) join it if they lie on it
  within tolerance (a depth difference [m], `_depth_gap`, or a height difference [m]);
- `region_interior`, `region_depth`: how far inside its region a pixel lies [px].
"""

from __future__ import annotations

import numba
import numpy as np

# `fill_pixels`' model: numpy scalars, not literals (`mapper.scanline`: constant arguments).
_INVERSE_DEPTH_MODEL = np.bool_(True)  # `fill_pixels` of the planes (inverse depth)
_LEVEL_MODEL = np.bool_(False)  # `fill_pixels` of the level regions (heights)


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _depth_gap(inv_a, inv_b):
    """|1/inv_a − 1/inv_b| [m] for inverse depths."""
    return abs(inv_a - inv_b) / (inv_a * inv_b)


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _overlap(a0, a1, b0, b1, gap):
    return a0 < b1 + gap and b0 < a1 + gap


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _row_index(seg_rows, height):
    """row_first (H+1,): segments of row r are row_first[r]:row_first[r+1]."""
    n_seg = seg_rows.shape[0]
    row_first = np.full(height + 1, n_seg, np.int64)
    for i in range(n_seg - 1, -1, -1):
        row_first[seg_rows[i]] = i
    for r in range(height - 1, -1, -1):
        if row_first[r] > row_first[r + 1]:
            row_first[r] = row_first[r + 1]
    return row_first


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _stable_order(values):
    """``np.argsort(values, kind="mergesort")``, bit for bit, compiled in a fraction of the time.

    Indices sorting ``values`` ascending, ties in index order, NaN last (numba's and numpy's
    order): a plain bottom-up merge sort.
    """
    n = values.shape[0]
    order = np.empty(n, np.int64)
    for i in range(n):
        order[i] = i
    merged = np.empty(n, np.int64)
    width = 1
    while width < n:
        for lo in range(0, n, 2 * width):
            mid = min(lo + width, n)
            hi = min(lo + 2 * width, n)
            i = lo
            j = mid
            for k in range(lo, hi):
                # The right run's head goes first only if strictly before (stable).
                if j < hi and (i >= mid or _before(values[order[j]], values[order[i]])):
                    merged[k] = order[j]
                    j += 1
                else:
                    merged[k] = order[i]
                    i += 1
        order, merged = merged, order
        width *= 2
    return order


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _before(a, b):
    """``a`` sorts strictly before ``b``: smaller, or a number against NaN (NaN last)."""
    return a < b or (b != b and a == a)


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def segment_labels(valid, seg_rows, seg_starts, seg_stops, plane_of):
    """(H, W) int64 plane id per pixel from segment assignments: -1 none, -2 invalid."""
    height, width = valid.shape
    labels = np.full((height, width), -2, np.int64)
    for r in range(height):
        for c in range(width):
            if valid[r, c]:
                labels[r, c] = -1
    for i in range(seg_rows.shape[0]):
        p = plane_of[i]
        if p >= 0:
            for c in range(seg_starts[i], seg_stops[i]):
                labels[seg_rows[i], c] = p
    return labels


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def fill_pixels(values, x, y, labels, sigma, model, factor, tolerance_floor_m, passes, inverse):
    """Let unassigned pixels join a 4-neighbour's label if they lie on it within tolerance.

    Label ``p`` predicts ``model[p, 0]·x + model[p, 1]·y + model[p, 2]`` at a pixel. With
    ``inverse`` the values and predictions are inverse depths (the planes of `plane_fits`) and
    the gap is their depth difference; otherwise they are heights (the level floors: model
    ``(0, 0, h)``) and the gap is the height difference. A pixel joins the best-fitting
    neighbour within ``factor·sigma + tolerance_floor_m``. Each pass looks only at the labels
    of the previous pass, so a label spreads by at most ``passes`` pixels. ``labels`` (H, W)
    int64 (-1 = none, -2 = invalid) is updated in place.
    """
    height, width = labels.shape
    for _ in range(passes):
        before = labels.copy()
        for r in range(height):
            for c in range(width):
                if before[r, c] != -1:
                    continue
                best = -1
                best_gap = 1e30
                tol = factor * sigma[r, c] + tolerance_floor_m
                for dr, dc in ((-1, 0), (1, 0), (0, -1), (0, 1)):
                    rr = r + dr
                    cc = c + dc
                    if rr < 0 or rr >= height or cc < 0 or cc >= width:
                        continue
                    p = before[rr, cc]
                    if p < 0:
                        continue
                    predicted = model[p, 0] * x[c] + model[p, 1] * y[r] + model[p, 2]
                    if inverse:
                        if not predicted > 0.0:
                            continue
                        gap = _depth_gap(values[r, c], predicted)
                    else:
                        gap = abs(values[r, c] - predicted)
                    if gap <= tol and gap < best_gap:
                        best = p
                        best_gap = gap
                if best >= 0:
                    labels[r, c] = best


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def region_interior(labels, margin_px):
    """(H, W) bool: the pixels in the interior of their region.

    A pixel is interior when its neighbours up to ``margin_px`` away up, down, left and right
    all carry its own region (``labels`` >= 0; beyond the image border counts as another
    region). ``margin_px`` 0: every labelled pixel.
    """
    height, width = labels.shape
    out = np.zeros((height, width), np.bool_)
    if margin_px == 0:
        for r in range(height):
            for c in range(width):
                out[r, c] = labels[r, c] >= 0
        return out
    # Pixels within margin_px of the image border are never interior; the others' tests are
    # combined without branches (bitwise &), and margin 1 (the defaults) has no loop over the
    # distances: 2× faster than short-circuit tests in a loop, which numba can't unroll.
    for r in range(margin_px, height - margin_px):
        for c in range(margin_px, width - margin_px):
            f = labels[r, c]
            inside = (
                (f >= 0)
                & (labels[r - 1, c] == f)
                & (labels[r + 1, c] == f)
                & (labels[r, c - 1] == f)
                & (labels[r, c + 1] == f)
            )
            for k in range(2, margin_px + 1):
                inside = (
                    inside
                    & (labels[r - k, c] == f)
                    & (labels[r + k, c] == f)
                    & (labels[r, c - k] == f)
                    & (labels[r, c + k] == f)
                )
            out[r, c] = inside
    return out


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def region_depth(labels, margin_px):
    """(H, W) int64: how deep inside its region each pixel lies [px], at most ``margin_px``.

    A labelled pixel's depth is the largest ``k`` <= ``margin_px`` for which its neighbours up
    to ``k`` away up, down, left and right all carry its own region (beyond the image border
    counts as another region): 0 on the region's border, and ``region_depth(labels, m) >= m``
    is `region_interior` ``(labels, m)``. -1 where ``labels`` < 0.
    """
    height, width = labels.shape
    out = np.full((height, width), -1, np.int64)
    for r in range(height):
        for c in range(width):
            f = labels[r, c]
            if f < 0:
                continue
            k = 0
            while k < margin_px:
                j = k + 1
                if (
                    r - j < 0
                    or r + j >= height
                    or c - j < 0
                    or c + j >= width
                    or labels[r - j, c] != f
                    or labels[r + j, c] != f
                    or labels[r, c - j] != f
                    or labels[r, c + j] != f
                ):
                    break
                k = j
            out[r, c] = k
    return out
