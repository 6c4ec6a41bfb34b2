"""Point-to-plane refinement of the heading correction (`HeadingParams.plane_refine_estimates`).

The heading's agreement score (`mapper.heading.heading_scores`) counts the pairs of keyframe
points that share a voxel. A surface that faces the camera path slides along itself under a
yaw error and adds only its density to those counts, which pulls the score's best candidate off
the truth where such surfaces dominate (`table`'s box face across the path: +1.44° on every
accepted estimate, session 39). A point-to-plane residual has no such pull: a point's distance
to the surface of its nearest point in another keyframe, measured along that surface's normal,
does not change when the surface slides along itself.

With a yaw correction ``δ`` a keyframe point lies at ``p(δ) = C_j + Rz(ψ_j + δ)·o`` (``C_j`` its
camera's world x, y, ``ψ_j`` the keyframe's robot yaw, ``o`` the point's offset from the
camera); its nearest point ``q`` of another keyframe ``k`` (within `match_m`, cameras at least
`min_baseline_m` apart) carries the 2-D normal ``n`` of ``k``'s own surface there (turned with
``q``). The residual ``r = n·(p − q)`` has the derivative

    a = dr/dδ = n⊥·(p − q) + n·((p − C_j)⊥ − (q − C_k)⊥),    v⊥ = (−v_y, v_x),

and Gauss-Newton steps ``δ ← δ − Σ w·r·a / Σ w·a²`` (``w``: the normal's planarity times a
Huber weight ``min(1, huber_m / |r|)``) with the correspondences found again at every step. It
refines the agreement score's estimate (the start): a point-to-plane fit only converges within
a few centimetres of the truth, which a 4° error at 2 m is not.

Normals (`keyframe_normals`): of each keyframe's own points, from the 2-D covariance of its
points within `normal_radius_m` (3-D distance, at least `MIN_NORMAL_POINTS` of them), the
eigenvector of the smaller eigenvalue; planarity ``1 − λ_min/λ_max`` at least
`MIN_PLANARITY`, else the point has no normal (weight 0).

Neighbours: both searches sort the points by a voxel key and look in the voxels around each
point, a row of (x, y) columns at a time, the points taken in key order (`_voxel_order`,
`_swept_neighbours`), exact within the radius. The normals take every point within
`NORMAL_RADIUS_M` (voxels of that size); the fit's correspondences, the `NEAREST` within
`MATCH_M`, come from spheres widened over `MATCH_TIERS` (a quarter, half, the whole radius,
voxels of a quarter) until one holds `NEAREST` points (`_nearest_matches`): the same matches,
bit for bit, where a surface seen by a dozen keyframes puts hundreds of points within the
radius (session 41: a fit 3.4–4.5× faster, 0.33 → 0.10 s on the stage's keyframes, 0.77 →
0.17 s on `room`'s, on the main thread of a run; session 58's sweep 1.29–1.39× more).

Measured (session 40). The estimator's final correction against the one each run needed (the
median over its frames of the believed camera's yaw error in the robot frame,
`bench/heading_trace.py`'s), depth replays seeds 1–8, mean |error| over the seeds, the score's
estimate → refined (a prototype of this module, scipy's k-d tree for the neighbours):
`table` 1.39 → 0.49° (its seeds 1 and 4 never accept an estimate: 2.21 and 1.58° either way),
`room` 0.59 → 0.29°, the zig-zag stage 0.50 → 0.23°, the stage 0.26 → 0.23°. Refined from 0
instead of from the score's estimate, the fit stays near 0 wherever the error is 3.5–4.8°
(stage seeds 6–8, `room` seed 6): hence a refinement, not an estimator of its own.

Replays, seeds 1–8, every accepted estimate refined (`head.plane_refine_estimates=1000`)
against none (0) (`fogsim.run.runner.replay_report` per recording; unsafe cells mean (worst),
`pose_error.map_heading_deg` mean (worst)):

- better: the zig-zag stage in depth 11.2 (44) → 6.9 (26) unsafe cells, heading 0.61 (1.16) →
  0.40 (0.70)°; `talos_course` stereo 51.5 (92) → 45.9 (59); `room` depth 1.5 (5) → 0.9 (5),
  heading 0.82 → 0.62°; `room` stereo 8.6 (13) → 7.6 (13); `stairs` stereo 48.6 (122) → 47.0
  (122); `stage_down` depth 0.1 (1) → 0 (0); `table` depth heading 1.40 (2.22) → 0.84 (2.22)°;
  `talos_course` depth heading 0.65 → 0.44°, `stage_down` stereo 0.60 → 0.39°;
- worse: the stage in depth 0 (0) → 1.4 (11) unsafe cells (seed 7, whose world map needs a
  correction that drifts with odometry's yaw from −3.55 to −4.8° while the refinement moves
  towards the robot frame's constant −3.49°: its map heading 0.35 → 0.59°), the stage in
  stereo 2.25 (5) → 2.9 (9) (seed 7 again, 0 → 9, though its heading improves 0.71 → 0.22°),
  `stage_down` stereo 3.75 (9) → 4.25 (9), the zig-zag stage's stereo seed 8's worst Table I
  row 0.76 → 2.82 mm, `talos_course` depth's worst heading 1.06 → 1.60° (seed 3);
- without `MAX_SHIFT_RAD`, `stairs` stereo seed 6 went 51 → 214 unsafe cells (heading 2.85 →
  9.16°).

`simulated_world`, `stairs` depth and `table` stereo are unchanged. The stage's 0 unsafe cells
on every seed is one of issue #11's criteria, so not every estimate is refined: only the first
(the default, 1), the one the maps are rebuilt with, which the frames mapped before it keep for
good. Against none, the same replays: `talos_course` stereo 51.5 (92) → 45.9 (59), `room`
depth 1.5 (5) → 0.9 (5) and 0.82 → 0.72°, `room` stereo 8.6 (13) → 7.0 (13), the stage in
stereo 2.25 (5) → 1.9 (5), `table` depth's heading 1.40 (2.22) → 0.84 (2.22)° (its unsafe cells
0.6 (4) → 0.75 (4)), `talos_course` depth 0.65 (1.06) → 0.49 (0.92)° and 0.1 (1) → 0 cells,
the zig-zag stage's depth heading 0.61 (1.16) → 0.57 (0.89)° (its cells 11.2 (44) both) and
stereo 31.8 (71) → 31.4 (71) cells (heading 0.49 → 0.54°); the stage in depth 0 (0) both. The
seeds-1–8 suites of both camera modes have every scenario's figures (README "Results").
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

__all__ = ["keyframe_normals", "refine_heading", "refined_heading"]

MIN_NORMAL_POINTS = 5
"""A normal needs this many points (the point itself included) within the radius."""

MIN_PLANARITY = 0.8
"""A normal needs its neighbourhood this elongated: ``1 − λ_min/λ_max`` (a line: 1, a blob: 0)."""

NEAREST = 8
"""Correspondences per point: its nearest points (its own keyframe's among them skipped)."""

NORMAL_RADIUS_M = 0.06
"""`keyframe_normals`' neighbourhood: two of the heading's 3 cm cells, about 10 points of a
surface at 2 m in the 88 × 72 image (7 mm between pixels at 1 m)."""

MATCH_M = 0.08
"""Correspondences lie within this [m]: the refinement starts from the agreement score's
estimate, within about 1° of the truth, 3.5 cm at 2 m, plus the depth noise."""

HUBER_M = 0.02
"""Residuals beyond this are down-weighted [m]: about the depth noise at the heading's 2 m."""

MIN_BASELINE_M = 0.15
"""Keyframes whose cameras are closer than this are not paired [m]: their disagreement under a
yaw error (the error times the baseline) is below the noise."""

MIN_SLOPE_M = 0.01
"""The residuals must move with the correction by this much on average [m/rad] (RMS of their
slopes): else the scene shows the yaw error nowhere (surfaces faced head-on, a wall slid along
itself) and the start is returned, not a step divided by almost nothing."""

ITERATIONS = 8
"""At most this many Gauss-Newton steps (each finds the correspondences again); the last one's
correction is taken whether or not the steps got below `TOLERANCE_RAD` (requiring that refused
most refinements of the stage's replays: the correspondences change by a point now and then,
and the steps wobble by a few hundredths of a degree)."""

TOLERANCE_RAD = math.radians(0.005)
"""The steps stop once one is smaller than this [rad]."""

MAX_SHIFT_RAD = math.radians(2.0)
"""A fit ending farther than this from its start is refused [rad] unless the caller bounds it
otherwise (`refined_heading`'s ``max_shift_rad``): the bound of the plane witness's two fits
(`mapper.heading.HeadingParams.plane_witness_deg`), whose agreement means something only
within the fit's reach. Session 40 bounded every refinement so, as the score's estimates were
within 1.7° of the truth wherever it stood out on the shipped scenes and a fit that slid off
(`stairs` stereo seed 6, a staircase faced head-on, 2.85 → 9.16° off) went much farther.
Since session 52 the refinement of an accepted estimate is bounded by the candidates' range
instead (`mapper.heading`, ``max_correction_deg``): on the held-out descending starts the first
estimate lay up to 3.8° off (`down_slant_turn` depth seed 3: +4.75° where +0.94° was needed;
its fit, moving 2.3° towards the need, was refused and the rebuild kept +4.75°), while
`stairs` stereo seed 6 replayed unbounded no longer slides (its first estimate 0.58° off either
way)."""

MATCH_TIERS = (1, 2, 4)
"""The correspondence search's spheres, in quarters of `MATCH_M` (`_nearest_matches`): the same
matches as one search over the whole radius, bit for bit, 3.4–4.5× faster (session 41: a fit
over 7 096 points of the stage 325 → 97 ms, 11 268 of `room` 774 → 172 ms)."""

_KEY_RANGE = np.int64(1 << 20)
"""Voxel indices are offset into ``[0, 2**20)`` per axis for the key (±10 km at 1 cm)."""


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _voxel_order(x, y, z, size):
    """Points sorted by voxel (``size`` cube): (order, sorted keys, the points (N, 3) in order).

    A key is ``(cx·R + cy)·R + cz`` (``R`` = `_KEY_RANGE`, each index offset into ``[0, R)``),
    so a point's voxel is its key's three fields: `_swept_neighbours` reads it there. The
    points are copied in key order, so that the searches read them one after the other.
    """
    n = x.shape[0]
    keys = np.empty(n, dtype=np.int64)
    half = _KEY_RANGE // 2
    for i in range(n):
        cx = np.int64(math.floor(x[i] / size)) + half
        cy = np.int64(math.floor(y[i] / size)) + half
        cz = np.int64(math.floor(z[i] / size)) + half
        keys[i] = (cx * _KEY_RANGE + cy) * _KEY_RANGE + cz
    order = np.argsort(keys, kind="mergesort")
    points = np.empty((n, 3))
    for q in range(n):
        i = order[q]
        points[q, 0], points[q, 1], points[q, 2] = x[i], y[i], z[i]
    return order, keys[order], points


_SWEPT_ROWS = sum(2 * reach + 1 for reach in MATCH_TIERS)
"""Rows of voxel columns `_nearest_matches` keeps a pointer for: ``2·reach + 1`` per tier."""


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _swept_neighbours(q, sorted_xyz, keys, r2, found_j, found_d2, reach, pointers, base):
    """The points within ``sqrt(r2)`` of the point at ``q`` in key order (itself too): how many.

    ``sorted_xyz, keys``: the points and their keys in key order (`_voxel_order`) with a voxel
    size of at least ``sqrt(r2) / reach``, so
    the ``(2·reach + 1)³`` voxels around the point hold every one of them. The voxels of one row
    of columns, ``(cx + dx, cy − reach … cy + reach)``, are consecutive keys, its voxels outside
    the z window skipped; the row starts at the key ``key_q + dx·R² − reach·R − reach`` (``R`` =
    ``_KEY_RANGE``), a fixed offset from the point's own key, so for points taken in key order
    (``q`` ascending) the row's first index (numpy's ``searchsorted``, left) only moves forward:
    ``pointers[base + dx + reach]`` walks to it from where the previous point left it. Session 49
    found the row (one binary search a row instead of one a column: a refinement over the
    stage's 7 096 keyframe points 95.5 → 73.9 ms), session 58 the pointers and the sorted reads
    (`_nearest_matches`); the same points in the same (key) order each time, bit for bit.
    ``found_j`` (M,) int64 and ``found_d2`` (M,) float64: their positions in key order
    (``order`` maps them to point indices) and squared distances.
    """
    n = keys.shape[0]
    found = 0
    key = keys[q]
    px, py, pz = sorted_xyz[q, 0], sorted_xyz[q, 1], sorted_xyz[q, 2]
    z_bits = _KEY_RANGE - 1
    low_z = (key & z_bits) - reach
    high_z = (key & z_bits) + reach
    reach_span = reach * _KEY_RANGE + reach  # from (cy, cz) to (cy ± reach, cz ± reach)
    for dx in range(-reach, reach + 1):
        row = key + dx * _KEY_RANGE * _KEY_RANGE  # the key of (cx + dx, cy, cz)
        first = row - reach_span
        last = row + reach_span
        slot = base + dx + reach
        at = pointers[slot]
        while at < n and keys[at] < first:
            at += 1
        pointers[slot] = at
        while at < n and keys[at] <= last:
            key_z = keys[at] & z_bits
            if key_z >= low_z and key_z <= high_z:
                ex = sorted_xyz[at, 0] - px
                ey = sorted_xyz[at, 1] - py
                ez = sorted_xyz[at, 2] - pz
                d2 = ex * ex + ey * ey + ez * ez
                if d2 <= r2:
                    found_j[found] = at
                    found_d2[found] = d2
                    found += 1
            at += 1
    return found


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _nearest_matches(order, keys, sorted_xyz, r2, matches, n_matches):
    """Every point's `NEAREST` nearest within ``sqrt(r2)`` (itself included), ties by index.

    The search widens over `MATCH_TIERS` (a quarter, half, the whole radius) until a sphere
    holds `NEAREST` points: then no point outside it is nearer than any inside, so the `NEAREST`
    nearest (ties by index) are the same as over the whole radius, where the matches lie among
    hundreds of points of a dozen keyframes seeing the same surface. The points are taken in
    key order (``order, keys, sorted_xyz``: `_voxel_order` with the voxel ``sqrt(r2) /
    MATCH_TIERS[-1]``), read in that order from its sorted copy, and each tier's rows are found by
    forward pointers (`_swept_neighbours`) instead of a binary search a row: session 58, the
    refinement 1.29–1.39× faster on the 7 fits of three replays (the stage in depth and stereo,
    `down_landing_turn` in stereo; 5 637–9 094 points, 71.6–141.0 → 51.6–105.4 ms, Zen 3 EPYC,
    `bench/bench_refine_ab.py --repeats 5`), the same corrections, information and RMS to the
    last bit. The candidates' order does not matter: the `NEAREST` smallest ``(d²,
    index)`` pairs, in that order, are the same whatever order they come in.

    Args:
        order: `_voxel_order`'s.
        keys: `_voxel_order`'s.
        sorted_xyz: `_voxel_order`'s points (M, 3) [m] in key order.
        r2: The squared match radius [m²].
        matches: (M, `NEAREST`) int64, out: each point's nearest, nearest first.
        n_matches: (M,) int64, out: how many (at most `NEAREST`).
    """
    n = keys.shape[0]
    pointers = np.zeros(_SWEPT_ROWS, dtype=np.int64)
    found_j = np.empty(n, dtype=np.int64)
    found_d2 = np.empty(n)
    best_d = np.empty(NEAREST)
    best_j = np.empty(NEAREST, dtype=np.int64)
    for q in range(n):
        i = order[q]
        count = 0
        base = np.int64(0)  # not a literal 0: one signature of `_swept_neighbours`
        for reach in MATCH_TIERS:
            scale = reach / MATCH_TIERS[-1]
            count = _swept_neighbours(
                q, sorted_xyz, keys, r2 * scale * scale, found_j, found_d2, reach, pointers,
                base,
            )  # fmt: skip
            base += 2 * reach + 1
            if count >= NEAREST:
                break
        found = 0
        for t in range(count):
            j = order[found_j[t]]
            d2 = found_d2[t]
            # Insert into the NEAREST closest (ties: the lower index first).
            slot = found
            while slot > 0 and (
                best_d[slot - 1] > d2 or (best_d[slot - 1] == d2 and best_j[slot - 1] > j)
            ):
                if slot < NEAREST:
                    best_d[slot] = best_d[slot - 1]
                    best_j[slot] = best_j[slot - 1]
                slot -= 1
            if slot < NEAREST:
                best_d[slot] = d2
                best_j[slot] = j
                found = min(found + 1, NEAREST)
        for t in range(found):
            matches[i, t] = best_j[t]
        n_matches[i] = found


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def keyframe_normals(offsets_xy, z, radius_m):
    """2-D unit normals of one keyframe's points and their planarity weights (module doc).

    Args:
        offsets_xy: (N, 2) the points' horizontal offsets from their camera [m].
        z: (N,) their heights [m].
        radius_m: Neighbourhood radius (3-D) [m].

    Returns:
        (normals (N, 2), weights (N,)): a point without a normal has weight 0 and normal 0.
    """
    n = offsets_xy.shape[0]
    normals = np.zeros((n, 2))
    weights = np.zeros(n)
    x = np.ascontiguousarray(offsets_xy[:, 0])
    y = np.ascontiguousarray(offsets_xy[:, 1])
    order, keys, sorted_xyz = _voxel_order(x, y, z, radius_m)
    r2 = radius_m * radius_m
    found_j = np.empty(n, dtype=np.int64)
    found_d2 = np.empty(n)
    reach = np.int64(1)  # int64s, as `_nearest_matches` passes them: one signature
    base = np.int64(0)
    pointers = np.zeros(2 * reach + 1, dtype=np.int64)
    for q in range(n):  # in key order: each point's neighbours, in key order, as before
        i = order[q]
        count = _swept_neighbours(q, sorted_xyz, keys, r2, found_j, found_d2, reach, pointers, base)
        sx = sy = sxx = sxy = syy = 0.0
        for t in range(count):
            j = order[found_j[t]]
            ex, ey = x[j] - x[i], y[j] - y[i]
            sx += ex
            sy += ey
            sxx += ex * ex
            sxy += ex * ey
            syy += ey * ey
        if count < MIN_NORMAL_POINTS:
            continue
        mx, my = sx / count, sy / count
        cxx = sxx / count - mx * mx
        cxy = sxy / count - mx * my
        cyy = syy / count - my * my
        mean = 0.5 * (cxx + cyy)
        spread = math.sqrt(0.25 * (cxx - cyy) ** 2 + cxy * cxy)
        high, low = mean + spread, mean - spread
        if high <= 0.0:
            continue
        planarity = 1.0 - max(low, 0.0) / high
        if planarity < MIN_PLANARITY:
            continue
        # Eigenvector of the smaller eigenvalue: (cxy, low - cxx) or (low - cyy, cxy).
        ax, ay = cxy, low - cxx
        bx, by = low - cyy, cxy
        if ax * ax + ay * ay < bx * bx + by * by:
            ax, ay = bx, by
        norm = math.sqrt(ax * ax + ay * ay)
        if norm == 0.0:
            continue
        normals[i, 0], normals[i, 1] = ax / norm, ay / norm
        weights[i] = planarity
    return normals, weights


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def refine_heading(
    offsets_xy,
    z_world,
    normals_xy,
    normal_weights,
    keyframe_of,
    camera_xy,
    yaw_rad,
    start_rad,
    match_m,
    huber_m,
    min_baseline_m,
    iterations,
    tolerance_rad,
    max_shift_rad,
):
    """The heading correction refined by point-to-plane Gauss-Newton steps (module doc).

    Args:
        offsets_xy: (M, 2) the keyframes' points' horizontal offsets from their camera [m].
        z_world: (M,) their world z [m].
        normals_xy: (M, 2) their keyframe's own 2-D normals, in the offsets' frame.
        normal_weights: (M,) the normals' planarity (0: no normal).
        keyframe_of: (M,) each point's keyframe.
        camera_xy: (K, 2) the keyframes' world camera positions [m].
        yaw_rad: (K,) their robot yaws [rad].
        start_rad: The correction to start from [rad].
        match_m: Correspondences lie within this (3-D) [m].
        huber_m: Residuals beyond this are down-weighted (Huber) [m].
        min_baseline_m: ... between points of keyframes whose cameras are this far apart [m].
        iterations: At most this many steps.
        tolerance_rad: Stop once a step is smaller [rad].
        max_shift_rad: A refinement that gets farther than this from the start is refused
            [rad].

    Returns:
        (correction [rad], Σ w·a² of the last step [m²/rad²], the weighted RMS of its
        residuals √(Σ w·r² / Σ w) [m]); (``start_rad``, 0, 0) when the residuals' slopes' RMS
        is below `MIN_SLOPE_M` (no correspondence, or none that shows the yaw), or the
        refinement is refused (``max_shift_rad``).
    """
    m = offsets_xy.shape[0]
    delta = start_rad
    information = 0.0
    rms = 0.0
    x = np.empty(m)
    y = np.empty(m)
    nx = np.empty(m)
    ny = np.empty(m)
    matches = np.empty((m, NEAREST), dtype=np.int64)
    n_matches = np.empty(m, dtype=np.int64)
    r2 = match_m * match_m
    b2 = min_baseline_m * min_baseline_m
    for _ in range(iterations):
        for i in range(m):
            k = keyframe_of[i]
            c = math.cos(yaw_rad[k] + delta)
            s = math.sin(yaw_rad[k] + delta)
            x[i] = camera_xy[k, 0] + c * offsets_xy[i, 0] - s * offsets_xy[i, 1]
            y[i] = camera_xy[k, 1] + s * offsets_xy[i, 0] + c * offsets_xy[i, 1]
            nx[i] = c * normals_xy[i, 0] - s * normals_xy[i, 1]
            ny[i] = s * normals_xy[i, 0] + c * normals_xy[i, 1]
        order, keys, sorted_xyz = _voxel_order(x, y, z_world, match_m / MATCH_TIERS[-1])
        numerator = 0.0
        information = 0.0
        weight_sum = 0.0
        square_sum = 0.0
        _nearest_matches(order, keys, sorted_xyz, r2, matches, n_matches)
        for i in range(m):
            ki = keyframe_of[i]
            for t in range(n_matches[i]):
                j = matches[i, t]
                kj = keyframe_of[j]
                if kj == ki or normal_weights[j] <= 0.0:
                    continue
                bx = camera_xy[kj, 0] - camera_xy[ki, 0]
                by = camera_xy[kj, 1] - camera_xy[ki, 1]
                if bx * bx + by * by < b2:
                    continue
                px, py = x[i] - x[j], y[i] - y[j]
                residual = nx[j] * px + ny[j] * py
                # n⊥·(p − q) + n·((p − C_i)⊥ − (q − C_j)⊥), v⊥ = (−v_y, v_x)
                ux = -(y[i] - camera_xy[ki, 1]) + (y[j] - camera_xy[kj, 1])
                uy = (x[i] - camera_xy[ki, 0]) - (x[j] - camera_xy[kj, 0])
                slope = -ny[j] * px + nx[j] * py + nx[j] * ux + ny[j] * uy
                weight = normal_weights[j]
                if abs(residual) > huber_m:
                    weight *= huber_m / abs(residual)
                numerator += weight * residual * slope
                information += weight * slope * slope
                weight_sum += weight
                square_sum += weight * residual * residual
        if information <= MIN_SLOPE_M * MIN_SLOPE_M * weight_sum:
            return start_rad, 0.0, 0.0
        rms = math.sqrt(square_sum / weight_sum)
        step = -numerator / information
        delta += step
        if abs(delta - start_rad) > max_shift_rad:
            return start_rad, 0.0, 0.0
        if abs(step) < tolerance_rad:
            break
    return delta, information, rms


def refined_heading(
    offsets_xy: NDArray[np.float64],
    z_world: NDArray[np.float64],
    normals_xy: NDArray[np.float64],
    normal_weights: NDArray[np.float64],
    keyframe_of: NDArray[np.int64],
    camera_xy: NDArray[np.float64],
    yaw_rad: NDArray[np.float64],
    start_rad: float,
    max_shift_rad: float = MAX_SHIFT_RAD,
) -> tuple[float, float, float]:
    """`refine_heading` with this module's constants: the correction [rad] and the fit's figures.

    Returns the correction, the fit's information Σ w·a² [m²/rad²] (0: refused, the correction
    ``start_rad``) and its residuals' weighted RMS [m]. ``max_shift_rad``: a fit ending farther
    than this from ``start_rad`` is refused (`MAX_SHIFT_RAD` unless the caller bounds it
    otherwise; ``math.inf``: never).

    The arrays as `refine_heading` takes them; ``camera_xy`` and ``yaw_rad`` are made
    contiguous float64 here, so every caller (the estimator, the warm-up) compiles the one
    signature.
    """
    refined, information, rms_m = refine_heading(
        offsets_xy,
        z_world,
        normals_xy,
        normal_weights,
        keyframe_of,
        np.ascontiguousarray(camera_xy, dtype=np.float64),
        np.ascontiguousarray(yaw_rad, dtype=np.float64),
        float(start_rad),
        MATCH_M,
        HUBER_M,
        MIN_BASELINE_M,
        ITERATIONS,
        TOLERANCE_RAD,
        float(max_shift_rad),
    )
    return float(refined), float(information), float(rms_m)
