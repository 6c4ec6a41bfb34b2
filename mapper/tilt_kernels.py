"""Numba kernels of the tilt correction: the per-point and per-plane numerics without the GIL.

The segmentation runs on a second thread beside the mapping (``fogsim.mapping.prefetch``);
numpy on small arrays holds the GIL between its calls, so these kernels (``nogil``) do the
tilt filter's work on the points (`turn_points`, `tilt_variances`) and the planes' normals
(`unit_normals`, `normal_sigma_deg`) in one pass each instead of a dozen numpy calls.

Bit for bit the numpy versions they replace: the same operations in the same order, numpy's
sums emulated where their order is not a plain loop (`mapper.pairwise.pairwise_sum`: numpy's
pairwise sum of a 1-D array), and the one matrix product on every point
``(points − origin)·turnᵀ``, which numpy hands to BLAS, as OpenBLAS's double kernels compute
it: each element a chain of fused multiply-adds over the three products (`_rotated`, `_fma`;
checked equal to numpy's ``@`` by
``tests/test_tilt_kernels.py``: a BLAS that sums otherwise would differ in the last bit).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from mapper.pairwise import pairwise_sum
from mapper.scanline import plane_moments, plane_refits, region_interior, renumber_planes
from mapper.scanline.steps import plane_inverse, plane_step, sums_beyond

__all__ = [
    "believed_points",
    "clearly_rigid",
    "corrected_planes",
    "ground_level",
    "normal_sigma_deg",
    "plane_geometry",
    "shifted_floors",
    "tilt_candidates",
    "tilt_consensus",
    "tilt_variances",
    "turn_points",
    "unit_normals",
]


_SHIFT = np.bool_(True)
_NO_SHIFT = np.bool_(False)
"""`rotate_points`'s ``shift`` from the kernels: numpy booleans, not literals (each literal is a
type of its own: `rotate_points` would be compiled once for each, and once more for Python's
bool)."""


@intrinsic
def _fma(typingctx, a, b, c):
    """``a·b + c`` rounded once (LLVM's ``llvm.fma.f64``: the FMA instruction, or libm's fma)."""
    sig = types.float64(types.float64, types.float64, types.float64)

    def codegen(context, builder, signature, args):
        double = ir.DoubleType()
        function = builder.module.declare_intrinsic(
            "llvm.fma", [double], ir.FunctionType(double, [double, double, double])
        )
        return builder.call(function, args)

    return sig, codegen


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _rotated(v0, v1, v2, rotation, j, single):
    """Element ``j`` of ``rotation·v`` as numpy's ``rows @ rotation.T`` gives it (OpenBLAS).

    Several rows (dgemm): ``fma(v2, r2, fma(v1, r1, v0·r0))``; a single row (dgemv):
    ``fma(v2, r2, fma(v0, r0, v1·r1))``, ``r = rotation[j]``.
    """
    if single:
        return _fma(v2, rotation[j, 2], _fma(v0, rotation[j, 0], v1 * rotation[j, 1]))
    return _fma(v2, rotation[j, 2], _fma(v1, rotation[j, 1], v0 * rotation[j, 0]))


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def believed_points(depth, pixel_index, rays_camera, rotation, pivot):
    """The valid pixels' points in the believed robot frame [m], as numpy gave them.

    ``(depth[pixel_index] · rays_camera[pixel_index])·rotationᵀ + pivot``: the product as BLAS
    computes it (module doc), so the points are those of the numpy expression bit for bit. One
    pass instead of numpy's gathers, broadcast product and matrix product: 0.20 → 0.07 ms on a
    stereo frame's 5 800 points in the shipped build (session 58, Zen 3 EPYC; 0.024 ms compiled
    for that CPU: the build's ``x86-64-v2`` code has no FMA instruction, so each `_fma` is a call
    into the C library). `mapper.pose_correction.stepped_planes` is their only reader.

    Args:
        depth: (H·W,) depths along the optical axis [m], row-major.
        pixel_index: (N,) the valid pixels' indices into ``depth``.
        rays_camera: (H·W, 3) camera-frame rays with unit z, row-major.
        rotation: (3, 3) C-order camera to robot rotation.
        pivot: (3,) the camera centre in the robot frame [m].

    Returns:
        (N, 3) points [m], z up.
    """
    n = pixel_index.shape[0]
    points = np.empty((n, 3))
    single = n == 1
    for i in range(n):
        pixel = pixel_index[i]
        d = depth[pixel]
        v0 = d * rays_camera[pixel, 0]
        v1 = d * rays_camera[pixel, 1]
        v2 = d * rays_camera[pixel, 2]
        for j in range(3):
            points[i, j] = _rotated(v0, v1, v2, rotation, j, single) + pivot[j]
    return points


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def turn_points(points, floor_ids, floor_heights, turn, origin, n_floors):
    """Points turned about ``origin`` and their floor regions' heights moved with them.

    ``(points − origin)·turnᵀ + origin`` (the product as BLAS computes it, module doc); each
    floor region's height moves by the mean z change of its points (sums in point order, as
    ``np.bincount``), and every floor point's floor height with it.

    Args:
        points: (N, 3) points [m] (robot frame).
        floor_ids: (N,) floor region of each point (-1: none).
        floor_heights: (N,) floor height of each point [m] (NaN: not floor).
        turn: (3, 3) the rotation.
        origin: (3,) the point turned about [m].
        n_floors: number of floor regions.

    Returns:
        (N, 3) turned points [m], (N,) their floor heights [m], (n_floors,) each region's
        height change [m] (0 for a region without points).
    """
    n = points.shape[0]
    turned = np.empty((n, 3))
    dz_sums = np.zeros(n_floors)
    counts = np.zeros(n_floors, dtype=np.int64)
    o0, o1, o2 = origin[0], origin[1], origin[2]
    single = n == 1
    for i in range(n):
        d0 = points[i, 0] - o0
        d1 = points[i, 1] - o1
        d2 = points[i, 2] - o2
        for j in range(3):
            turned[i, j] = _rotated(d0, d1, d2, turn, j, single) + origin[j]
        region = floor_ids[i]
        if region >= 0:
            dz_sums[region] += turned[i, 2] - points[i, 2]
            counts[region] += 1
    region_dz = np.empty(n_floors)
    for region in range(n_floors):
        region_dz[region] = dz_sums[region] / max(counts[region], 1)
    heights = floor_heights.copy()
    for i in range(n):
        region = floor_ids[i]
        if region >= 0:
            heights[i] += region_dz[region]
    return turned, heights, region_dz


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def tilt_variances(
    points,
    plane_ids,
    counts,
    pivot,
    normals,
    rms_m,
    extents_m,
    min_noise_m,
    correlation,
    min_plane_pixels,
    min_extent_m,
    min_normal_z,
):
    """Each plane's normal variance and whether it is in the tilt's consensus.

    `mapper.tilt_filter.measured_tilt`'s per-plane part: the ray to each plane's centroid
    (mean of its points, from ``pivot``), the RMS residual (at least ``min_noise_m``)
    projected on the normal along it, ``σ_p² = c·σ⊥²·12/n·(1/a² + 1/b²)``; a plane is in the
    consensus when its normal's |z| is at least ``min_normal_z``, it has ``min_plane_pixels``
    pixels, a minor extent of ``min_extent_m`` and a finite positive variance.

    Args:
        points: (N, 3) the frame's corrected points [m].
        plane_ids: (N,) plane of each point (-1: none).
        counts: (P,) pixels of each plane.
        pivot: (3,) the correction's pivot (camera centre) [m].
        normals: (P, 3) unit normals (corrected frame).
        rms_m: (P,) RMS depth residuals [m].
        extents_m: (P, 2) in-plane extents, minor first [m].
        min_noise_m: lower bound of the residual [m].
        correlation: the noise's variance inflation of means (≥ 1).
        min_plane_pixels: fewest pixels of a consensus plane.
        min_extent_m: smallest minor extent of a consensus plane [m].
        min_normal_z: cos of ``tilt_consensus_deg``.

    Returns:
        (P,) variances [rad²] (inf or NaN for a degenerate plane), (P,) bool consensus, and
        the sum of the consensus planes' information ``Σ 1/σ_p²`` (numpy's summation order).
    """
    n_planes = counts.shape[0]
    sums = np.zeros((n_planes, 3))
    for i in range(plane_ids.shape[0]):
        plane = plane_ids[i]
        if plane >= 0:
            sums[plane, 0] += points[i, 0]
            sums[plane, 1] += points[i, 1]
            sums[plane, 2] += points[i, 2]
    variance = np.empty(n_planes)
    consensus = np.zeros(n_planes, dtype=np.bool_)
    information = np.empty(n_planes)
    n_consensus = 0
    for p in range(n_planes):
        pixels = max(counts[p], 1)
        r0 = sums[p, 0] / pixels - pivot[0]
        r1 = sums[p, 1] / pixels - pivot[1]
        r2 = sums[p, 2] / pixels - pivot[2]
        norm = math.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
        r0 /= norm
        r1 /= norm
        r2 /= norm
        residual = rms_m[p] if not rms_m[p] < min_noise_m else min_noise_m  # NaN stays NaN
        # np.einsum("pi,pi->p") of 3-vectors sums in two lanes: (x0·y0 + x2·y2) + x1·y1.
        along_ray = (r0 * normals[p, 0] + r2 * normals[p, 2]) + r1 * normals[p, 1]
        perpendicular = residual * abs(along_ray)
        minor = extents_m[p, 0]
        major = extents_m[p, 1]
        v = (
            correlation
            * (perpendicular * perpendicular)
            * 12.0
            / counts[p]
            * (1.0 / (minor * minor) + 1.0 / (major * major))
        )
        variance[p] = v
        if (
            abs(normals[p, 2]) >= min_normal_z
            and counts[p] >= min_plane_pixels
            and minor >= min_extent_m
            and math.isfinite(v)
            and v > 0.0
        ):
            consensus[p] = True
            information[n_consensus] = 1.0 / v
            n_consensus += 1
    return variance, consensus, pairwise_sum(information[:n_consensus])


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def unit_normals(coefficients, rotation):
    """Unit normals of planes ``(A, B, C)`` in the camera frame and turned up in the robot's.

    Args:
        coefficients: (P, ≥3) plane table, the normal's direction in its first 3 columns.
        rotation: (3, 3) camera to robot rotation.

    Returns:
        (P, 3) unit normals in the camera frame, (P, 3) rotated by ``rotation`` (the product as
        BLAS computes it, module doc) and turned to point up (z ≥ 0), (P,) the norms of
        ``(A, B, C)``.
    """
    n = coefficients.shape[0]
    camera = np.empty((n, 3))
    robot = np.empty((n, 3))
    norms = np.empty(n)
    single = n == 1
    for p in range(n):
        a, b, c = coefficients[p, 0], coefficients[p, 1], coefficients[p, 2]
        norm = math.sqrt(a * a + b * b + c * c)
        norms[p] = norm
        u0, u1, u2 = a / norm, b / norm, c / norm
        camera[p, 0], camera[p, 1], camera[p, 2] = u0, u1, u2
        for j in range(3):
            robot[p, j] = _rotated(u0, u1, u2, rotation, j, single)
        sign = -1.0 if robot[p, 2] < 0.0 else 1.0
        for j in range(3):
            robot[p, j] *= sign
    return camera, robot, norms


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def normal_sigma_deg(plane_table, correlation, min_inv_sigma):
    """Standard deviation of each plane's normal direction [deg] from its inverse-depth fit.

    `mapper.segmentation._normal_sigma_deg` (its doc) in one pass: the fit's covariance
    ``c·max(s², min_inv_sigma²)·M⁻¹``, its part across the normal ``tr(C) − uᵀCu`` (clipped
    at 0), ``sqrt(·)/|(A, B, C)|`` in degrees; inf where that is not finite.

    Args:
        plane_table: (P, 13) `mapper.scanline.plane_pixels.plane_fits` table.
        correlation: the noise's variance inflation of means (≥ 1).
        min_inv_sigma: (P,) lower bound of each plane's inverse-depth noise [1/m].
    """
    n = plane_table.shape[0]
    sigma = np.empty(n)
    for p in range(n):
        a, b, c = plane_table[p, 0], plane_table[p, 1], plane_table[p, 2]
        norm = math.sqrt(a * a + b * b + c * c)
        unit = (a / norm, b / norm, c / norm)
        floor = min_inv_sigma[p] * min_inv_sigma[p]
        s2 = plane_table[p, 3]
        variance = s2 if s2 >= floor else (floor if floor > s2 else np.nan)  # as np.maximum
        scale = correlation * variance
        along = 0.0
        for i in range(3):
            for j in range(3):
                along += unit[i] * (scale * plane_table[p, 4 + 3 * i + j]) * unit[j]
        trace = (scale * plane_table[p, 4] + scale * plane_table[p, 8]) + scale * plane_table[p, 12]
        across = trace - along
        across = across if not across < 0.0 else 0.0
        value = math.degrees(math.sqrt(across) / norm)
        sigma[p] = value if math.isfinite(value) else np.inf
    return sigma


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def rotate_points(points, rotation, before, after, shift):
    """``(points − before)·rotationᵀ (+ after)``, the product as BLAS computes it (module doc).

    Args:
        points: (N, 3) points or directions.
        rotation: (3, 3) the rotation.
        before: (3,) subtracted first.
        after: (3,) added last when ``shift`` (an added 0 would turn −0.0 into 0.0).
        shift: add ``after``.

    Returns:
        (N, 3) the rotated points.
    """
    n = points.shape[0]
    rotated = np.empty((n, 3))
    single = n == 1
    for i in range(n):
        d0 = points[i, 0] - before[0]
        d1 = points[i, 1] - before[1]
        d2 = points[i, 2] - before[2]
        for j in range(3):
            value = _rotated(d0, d1, d2, rotation, j, single)
            rotated[i, j] = value + after[j] if shift else value
    return rotated


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def plane_geometry(
    labels,
    grown_labels,
    pixel_index,
    counts,
    plane_table,
    rotation,
    pivot,
    rays_camera,
    depth,
    inv_depth,
    x,
    y,
    fx,
    fy,
    min_plane_pixels,
    min_noise_m,
    normal_margin_px,
    refit_sigma,
    min_inv_depth,
    correlation,
):
    """The planes' table and the tilt's inputs in one call (`mapper.segmentation.segment_depth`).

    Keeps the planes of ``min_plane_pixels`` or more with a finite fit and renumbers them
    (`mapper.scanline.plane_pixels.renumber_planes`); their unit normals (`unit_normals`),
    centroids, covariance eigenvalues and areas (`mapper.scanline.plane_pixels.plane_moments`, on
    the grown pixels), centroids in the robot frame (`rotate_points` about the origin, plus
    ``pivot``), RMS depth residuals ``sqrt(s²)·z_c²`` and noise floors ``min_noise_m/z_c²`` at the
    centroids; the refit on the interior pixels (`mapper.scanline.regions.region_interior` with
    ``normal_margin_px`` > 0, `mapper.scanline.plane_pixels.plane_refits`), its normals in the
    robot frame and their information ``1/σ²`` (`normal_sigma_deg`, σ in degrees). The same
    operations in the same order as the numpy code it replaced (bit for bit).

    Args:
        labels: (H, W) plane of each pixel after the fill (-1 none, -2 no measurement).
        grown_labels: (H, W) the same before the fill.
        pixel_index: (N,) the valid pixels' indices into the flattened image.
        counts: (P,) pixels of each plane (`mapper.scanline.plane_pixels.plane_fits`).
        plane_table: (P, 13) the planes' fits (`mapper.scanline.plane_pixels.plane_fits`).
        rotation: (3, 3) C-order camera to robot rotation.
        pivot: (3,) the camera centre in the robot frame [m].
        rays_camera: (H·W, 3) camera-frame rays with unit z, row-major.
        depth: (H, W) depths [m] (NaN: none).
        inv_depth: (H, W) inverse depths [1/m].
        x: (W,) normalised image x of the columns.
        y: (H,) normalised image y of the rows.
        fx: focal length along x [px].
        fy: focal length along y [px].
        min_plane_pixels: planes with fewer pixels are dissolved.
        min_noise_m: lower bound of the depth noise [m].
        normal_margin_px: ``plane_normal_margin_px`` (0: every pixel refits).
        refit_sigma: ``plane_refit_sigma`` (`mapper.scanline.plane_pixels.plane_refits`).
        min_inv_depth: 1 / ``max_depth_m`` [1/m].
        correlation: ``noise_correlation_factor``.

    Returns:
        (N,) the valid pixels' renumbered planes, and per kept plane (K,) pixel counts,
        (K, 3) unit normals in the robot frame (up), (K, 3) centroids in the robot frame [m],
        (K, 3) eigenvalues [m²], (K,) areas [m²], (K,) RMS residuals [m], (K, 3) the refit's
        unit normals in the robot frame (up) and (K,) their information [1/deg²].
    """
    n_planes = counts.shape[0]
    keep = np.empty(n_planes, np.bool_)
    n_kept = np.int64(0)  # not a literal 0: one signature of plane_moments
    for p in range(n_planes):
        keep[p] = counts[p] >= min_plane_pixels and np.isfinite(plane_table[p, 0])
        if keep[p]:
            n_kept += 1
    _, refit_labels, plane_ids, grown_ids, kept_counts = renumber_planes(
        labels, grown_labels, pixel_index, keep
    )
    table = np.empty((n_kept, plane_table.shape[1]))
    k = 0
    for p in range(n_planes):
        if keep[p]:
            for j in range(plane_table.shape[1]):
                table[k, j] = plane_table[p, j]
            k += 1
    normals_camera, normals, _ = unit_normals(table, rotation)
    centroids_camera, eigen, areas = plane_moments(
        rays_camera, depth, pixel_index, grown_ids, normals_camera, n_kept, fx, fy
    )
    centroids = rotate_points(centroids_camera, rotation, np.zeros(3), pivot, _SHIFT)
    rms = np.empty(n_kept)
    min_inv_sigma = np.empty(n_kept)
    for p in range(n_kept):
        z2 = centroids_camera[p, 2] * centroids_camera[p, 2]
        rms[p] = math.sqrt(table[p, 3]) * z2
        min_inv_sigma[p] = min_noise_m / z2
    if normal_margin_px > 0:
        interior = region_interior(refit_labels, normal_margin_px)
        height, width = refit_labels.shape
        for r in range(height):
            for c in range(width):
                if not interior[r, c]:
                    refit_labels[r, c] = -1
    tilt_table = plane_refits(
        inv_depth, x, y, refit_labels, table, refit_sigma, min_noise_m, min_inv_depth
    )
    _, tilt_normals, _ = unit_normals(tilt_table, rotation)
    sigma = normal_sigma_deg(tilt_table, correlation, min_inv_sigma)
    information = np.empty(n_kept)
    for p in range(n_kept):
        information[p] = 1.0 / (sigma[p] * sigma[p])
    return plane_ids, kept_counts, normals, centroids, eigen, areas, rms, tilt_normals, information


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _clipped_extent(variance):
    """``sqrt(12·np.maximum(variance, 0))``: a footprint width from a variance [m] (NaN stays)."""
    clipped = variance if variance >= 0.0 else (0.0 if variance < 0.0 else np.nan)
    return math.sqrt(12.0 * clipped)


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def tilt_candidates(normals, gram, eigen, counts, min_abs_z, min_dot, min_pixels, min_extent_m):
    """The planes that may steer the tilt and which of them agree (`estimate_tilt`).

    Args:
        normals: (P, 3) unit normals in the robot frame.
        gram: (P, P) ``normals @ normals.T`` (numpy's, so its float order).
        eigen: (P, 3) the planes' covariance eigenvalues [m²], ascending.
        counts: (P,) their pixels.
        min_abs_z: cos of ``max_tilt_correction_deg``.
        min_dot: cos of ``tilt_consensus_deg``.
        min_pixels: ``min_plane_pixels``.
        min_extent_m: ``min_plane_extent_m`` [m].

    Returns:
        (P,) bool the candidates (normal within the angle of vertical, enough pixels, wide
        enough), (P, P) float64 1 where two candidates agree (else 0), and how many there are.
    """
    n = normals.shape[0]
    candidates = np.empty(n, np.bool_)
    n_candidates = 0
    for p in range(n):
        candidates[p] = (
            abs(normals[p, 2]) >= min_abs_z
            and counts[p] >= min_pixels
            and _clipped_extent(eigen[p, 1]) >= min_extent_m
        )
        if candidates[p]:
            n_candidates += 1
    agree = np.zeros((n, n))
    for p in range(n):
        for q in range(n):
            if gram[p, q] >= min_dot and candidates[p] and candidates[q]:
                agree[p, q] = 1.0
    return candidates, agree, n_candidates


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def tilt_consensus(normals, weights, candidates, agree, support, min_abs_z):
    """The consensus's weighted mean normal (`estimate_tilt`).

    The reference is the candidate of the largest ``support`` (the first of equals, as
    ``np.argmax``); the candidates agreeing with it are summed in plane order weighted by
    ``weights`` (numpy's sum over the rows: a plain loop) and normalised by the norm as
    ``np.linalg.norm`` took it on the AVX-512 machine this was written on (OpenBLAS's ddot:
    ``fma(m2, m2, fma(m1, m1, m0·m0))``), on every CPU: OpenBLAS's ddot on a Zen 3 EPYC sums
    plainly (session 58: 2 144 of 20 000 random 3-vectors differ in the last bit), so numpy's
    own norm would make the tilt depend on the CPU (`tests/test_fused_kernels.py` spells the
    fused order out).

    Args:
        normals: (P, 3) unit normals in the robot frame.
        weights: (P,) the planes' weights.
        candidates: (P,) bool, `tilt_candidates`.
        agree: (P, P) `tilt_candidates`'s agreement.
        support: (P,) ``agree @ weights`` (numpy's, so its float order).
        min_abs_z: cos of ``max_tilt_correction_deg``.

    Returns:
        (3,) the unit mean normal, the planes averaged, and whether it is within
        ``max_tilt_correction_deg`` of vertical.
    """
    n = normals.shape[0]
    best = -1
    best_support = -1.0
    for p in range(n):
        value = support[p] if candidates[p] else -1.0
        if best < 0 or value > best_support or (value != value and best_support == best_support):
            best = p
            best_support = value
            if value != value:
                break
    mean = np.zeros(3)
    used = 0
    for p in range(n):
        if candidates[p] and agree[best, p] != 0.0:
            used += 1
            for j in range(3):
                term = normals[p, j] * weights[p]
                mean[j] = term if used == 1 else mean[j] + term
    norm = math.sqrt(_fma(mean[2], mean[2], _fma(mean[1], mean[1], mean[0] * mean[0])))
    for j in range(3):
        mean[j] /= norm
    return mean, used, abs(mean[2]) >= min_abs_z


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def clearly_rigid(transform, tolerance):
    """Whether a 4×4 matrix passes `mapper.validation.rigid_transform` with room to spare.

    Finite; ``max |R·Rᵀ − I|`` (scalar products) at most half of ``tolerance``; ``det R``
    above 0.5 (an orthonormal R has ±1); last row within 1e-12 of 0 0 0 1. Such a matrix
    passes `rigid_transform`, whose BLAS product and LU determinant differ from these by a
    few units in the last place; a False answer means "ask `rigid_transform`" (its verdict
    and message), not "not rigid". The per-frame check of `segment_depth` in a few scalar
    operations instead of numpy's dozen calls on 3×3 arrays (30 µs a frame).

    Args:
        transform: (4, 4) float64 matrix.
        tolerance: `mapper.limits.RIGID_TOLERANCE`.
    """
    for i in range(4):
        for j in range(4):
            if not math.isfinite(transform[i, j]):
                return False
    deviation = 0.0
    for i in range(3):
        for j in range(3):
            dot = (
                transform[i, 0] * transform[j, 0]
                + transform[i, 1] * transform[j, 1]
                + transform[i, 2] * transform[j, 2]
            )
            deviation = max(deviation, abs(dot - (1.0 if i == j else 0.0)))
    determinant = (
        transform[0, 0] * (transform[1, 1] * transform[2, 2] - transform[1, 2] * transform[2, 1])
        - transform[0, 1] * (transform[1, 0] * transform[2, 2] - transform[1, 2] * transform[2, 0])
        + transform[0, 2] * (transform[1, 0] * transform[2, 1] - transform[1, 1] * transform[2, 0])
    )
    last_row = max(
        abs(transform[3, 0]), abs(transform[3, 1]), abs(transform[3, 2]), abs(transform[3, 3] - 1.0)
    )
    return deviation <= 0.5 * tolerance and determinant > 0.5 and last_row <= 1e-12


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def corrected_planes(
    centroids, normals, rotation, pivot, eigen, counts, min_abs_z, min_pixels, min_extent_m
):
    """The planes' centroids and normals after the tilt correction, extents and floor shape.

    `rotate_points` of the centroids about ``pivot`` and of the normals, ``sqrt(12·
    max(eigen[:, 1:], 0))``, and the planes of floor shape (normal within
    ``floor_max_normal_angle_deg`` of vertical: ``|n_z| ≥ min_abs_z``; enough pixels; minor
    extent ≥ ``min_extent_m``).

    Args:
        centroids: (P, 3) centroids in the robot frame [m].
        normals: (P, 3) unit normals in the robot frame.
        rotation: (3, 3) the tilt correction.
        pivot: (3,) its centre [m].
        eigen: (P, 3) covariance eigenvalues [m²], ascending.
        counts: (P,) pixels of each plane.
        min_abs_z: cos of ``floor_max_normal_angle_deg``.
        min_pixels: ``min_plane_pixels``.
        min_extent_m: ``min_plane_extent_m`` [m].

    Returns:
        (P, 3) corrected centroids [m], (P, 3) corrected normals, (P, 2) extents [m] (minor
        first) and (P,) bool floor shape.
    """
    centroids_c = rotate_points(centroids, rotation, pivot, pivot, _SHIFT)
    normals_c = rotate_points(normals, rotation, np.zeros(3), np.zeros(3), _NO_SHIFT)
    n = centroids.shape[0]
    extents = np.empty((n, 2))
    is_floor = np.empty(n, np.bool_)
    for p in range(n):
        extents[p, 0] = _clipped_extent(eigen[p, 1])
        extents[p, 1] = _clipped_extent(eigen[p, 2])
        is_floor[p] = (
            abs(normals_c[p, 2]) >= min_abs_z
            and counts[p] >= min_pixels
            and extents[p, 0] >= min_extent_m
        )
    return centroids_c, normals_c, extents, is_floor


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _first_min(values):
    """``np.argmin`` of a 1-D float array: the first smallest, or the first NaN."""
    best = 0
    for i in range(values.shape[0]):
        if values[i] != values[i]:
            return i
        if values[i] < values[best]:
            best = i
    return best


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def ground_level(heights, areas, is_floor, expected_z_m, window_m):
    """The floor region nearest the expected ground plane (`mapper.pose_correction.ground_shift`).

    Regions that are floors within ``window_m`` of ``expected_z_m`` and have at least a
    quarter of the largest such region's area compete; the nearest wins (the first of equals).

    Args:
        heights: (F,) the regions' heights [m].
        areas: (F,) their areas [m²].
        is_floor: (F,) bool, the regions that are floors.
        expected_z_m: z of the expected ground plane [m].
        window_m: the search window [m].

    Returns:
        Whether one was found, and its height minus ``expected_z_m`` [m] (0 if none).
    """
    n = heights.shape[0]
    near = np.empty(n, np.bool_)
    largest = -np.inf
    found = False
    for f in range(n):
        near[f] = is_floor[f] and abs(heights[f] - expected_z_m) <= window_m
        if near[f]:
            area = areas[f]
            if not found or area != area or (largest == largest and area > largest):
                largest = area  # NaN wins, as in np.max
            found = True
    if not found:
        return False, 0.0
    offsets = np.empty(n)
    for f in range(n):
        offset = heights[f] - expected_z_m
        offsets[f] = abs(offset) if near[f] and areas[f] >= 0.25 * largest else np.inf
    return True, heights[_first_min(offsets)] - expected_z_m


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def shifted_floors(heights, is_floor, z_shift_m, expected_z_m, find_ground):
    """The floor regions' heights after the ground shift, and the ground's height.

    Args:
        heights: (F,) the regions' heights before the shift [m].
        is_floor: (F,) bool, the regions that are floors.
        z_shift_m: the ground shift [m].
        expected_z_m: z of the expected ground plane [m].
        find_ground: whether to look for the ground's height.

    Returns:
        (F,) shifted heights [m], (F,) the same for floors and NaN for the other regions, and
        the shifted height of the floor nearest ``expected_z_m`` (the first of equals; NaN if
        not ``find_ground``).
    """
    n = heights.shape[0]
    shifted = np.empty(n)
    floor_heights = np.empty(n)
    offsets = np.empty(n)
    for f in range(n):
        shifted[f] = heights[f] + z_shift_m
        floor_heights[f] = shifted[f] if is_floor[f] else np.nan
        offsets[f] = abs(shifted[f] - expected_z_m) if is_floor[f] else np.inf
    ground_m = shifted[_first_min(offsets)] if find_ground and n > 0 else np.nan
    return shifted, floor_heights, ground_m


SMALL_BUCKET = 32
"""A bucket of `_rank_value` with at most this many values is sorted by insertion, a larger one
by ``np.sort`` (a bucket holds about 4 values; many equal or clustered values fill one)."""


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _bucket_values(values, out, offsets, done):
    """``values`` moved into ``out`` by bucket: the order statistics without a whole sort.

    The buckets cut [min, max] of ``values`` into ``offsets.size − 1`` equal widths; a value's
    bucket never decreases as the value grows (a floor of a non-decreasing expression), so the
    values of bucket ``b`` are exactly the ranks ``offsets[b]`` … ``offsets[b + 1] − 1`` (0 =
    the smallest), in ``out`` at those places, unsorted until `_rank_value` asks for one of
    them (``done[b]``). All equal: one sorted bucket.

    Args:
        values: (n,) finite values, n ≥ 1.
        out: (n,) filled with the values by bucket.
        offsets: (B + 1,) set to each bucket's first place in ``out`` and ``n``.
        done: (B,) set to whether each bucket is sorted in ``out`` yet.
    """
    n = values.size
    buckets = offsets.size - 1
    lowest = values[0]
    highest = values[0]
    for i in range(1, n):
        lowest = min(lowest, values[i])
        highest = max(highest, values[i])
    offsets[:] = 0
    done[:] = False
    if not highest > lowest:
        out[:] = values
        offsets[1:] = n
        done[:] = True
        return
    scale = buckets / (highest - lowest)  # inf for a range below about 1e-307
    for i in range(n):
        offsets[_bucket_of(values[i], lowest, scale, buckets) + 1] += 1
    for b in range(buckets):
        offsets[b + 1] += offsets[b]
    fill = offsets[:-1].copy()
    for i in range(n):
        b = _bucket_of(values[i], lowest, scale, buckets)
        out[fill[b]] = values[i]
        fill[b] += 1


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _bucket_of(value, lowest, scale, buckets):
    """The bucket of ``value`` >= ``lowest``: never decreasing in it, always in [0, buckets).

    With ``scale`` finite, ``(value − lowest)·scale`` lies in [0, buckets] (the range times
    ``scale`` is ``buckets``); with ``scale`` overflowed (a range below about 1e-307) the
    lowest value is bucket 0 and every other the last (not ``int`` of ``0 · inf``, NaN).
    """
    if scale < math.inf:  # the same for every value of a call: the branch leaves the loop
        return min(int((value - lowest) * scale), buckets - 1)
    return 0 if not value > lowest else buckets - 1


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _rank_value(out, offsets, done, rank):
    """The value of rank ``rank`` (0 = the smallest) of `_bucket_values`' buckets.

    Its bucket is sorted in place the first time one of its ranks is asked for.
    """
    b = np.searchsorted(offsets, rank, side="right") - 1
    if not done[b]:
        first = offsets[b]
        last = offsets[b + 1]
        if last - first > SMALL_BUCKET:
            out[first:last] = np.sort(out[first:last])
        else:
            for i in range(first + 1, last):
                value = out[i]
                j = i - 1
                while j >= first and out[j] > value:
                    out[j + 1] = out[j]
                    j -= 1
                out[j + 1] = value
        done[b] = True
    return out[rank]


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _bucketed_quantile(out, offsets, done, q):
    """The ``q`` quantile of `_bucket_values`' values as numpy's ``quantile`` (``linear``)."""
    position = q * (out.size - 1)
    below = math.floor(position)
    above = min(below + 1, out.size - 1)
    t = position - below
    a = _rank_value(out, offsets, done, below)
    b = _rank_value(out, offsets, done, above)
    difference = b - a
    return b - difference * (1.0 - t) if t >= 0.5 else a + difference * t


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _points_by_plane(plane_ids, planes):
    """(order, starts): the point indices grouped by plane, each plane's in index order.

    A counting sort: ``order[starts[p]:starts[p + 1]]`` are plane ``p``'s points (ids outside
    ``[0, planes)`` belong to none), as a stable argsort of the ids would list them.
    """
    starts = np.zeros(planes + 1, dtype=np.int64)
    for pid in plane_ids:
        if 0 <= pid < planes:
            starts[pid + 1] += 1
    for p in range(planes):
        starts[p + 1] += starts[p]
    fill = starts[:-1].copy()
    order = np.empty(starts[planes], dtype=np.int64)
    for i in range(plane_ids.size):
        pid = plane_ids[i]
        if 0 <= pid < planes:
            order[fill[pid]] = i
            fill[pid] += 1
    return order, starts


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def stepped_plane_flags(
    points, plane_ids, tested, quantiles, max_step_t, correlation, min_turn_rad
):
    """`mapper.pose_correction.stepped_planes`'s test of each plane (its docstring).

    The step model ``z = a + b·x + c·y + Δ·[s > s₀]`` is solved through the plane's 3 × 3
    normal equations (`mapper.scanline.steps.plane_inverse`) and the Schur complement of the
    step's column (`mapper.scanline.steps.plane_step`) — the 4 × 4 solution of every split from
    the sums of the points beyond it. The splits are the quantiles of the points' ``s`` along
    the downhill direction, taken from value buckets (`_bucket_values`: only the buckets
    holding their ranks are sorted, not all points: the test 0.35 → 0.17 ms a frame on the
    stage's stereo frames, the same values); each point's sums go to the run between two
    splits it lies in and the runs are added from the top (`sums_beyond`).

    Args:
        points: (N, 3) points [m], z up.
        plane_ids: (N,) plane of each point (-1 or P and above: none).
        tested: (P,) the planes to test.
        quantiles: (K,) split quantiles along the downhill direction, ascending.
        max_step_t: The step's t-statistic above which a plane is stepped.
        correlation: The noise correlation factor τ ≥ 1 (the t-statistic's variance × τ).
        min_turn_rad: The least change of slope the step must make [rad].

    Returns:
        (P,) bool: stepped planes.
    """
    stepped = np.zeros(tested.size, dtype=np.bool_)
    order, starts = _points_by_plane(plane_ids, tested.size)
    splits_n = quantiles.size
    splits = np.empty(splits_n)
    # Per run between splits (run k: splits[k-1] < s <= splits[k]; run K: beyond the last):
    # points, Σx, Σy, Σz; split k's step column sums the runs beyond it (`sums_beyond`).
    runs = np.empty((splits_n + 1, 4))
    beyond = np.empty((splits_n + 2, 4))
    for p in range(tested.size):
        first = starts[p]
        n = starts[p + 1] - first
        if not tested[p] or n < 5:
            continue
        mx = my = mz = 0.0
        for i in range(n):
            q = order[first + i]
            mx += points[q, 0]
            my += points[q, 1]
            mz += points[q, 2]
        mx /= n
        my /= n
        mz /= n
        x = np.empty(n)
        y = np.empty(n)
        z = np.empty(n)
        sx = sy = sz = sxx = sxy = syy = sxz = syz = szz = 0.0
        for i in range(n):
            q = order[first + i]
            xi = points[q, 0] - mx
            yi = points[q, 1] - my
            zi = points[q, 2] - mz
            x[i] = xi
            y[i] = yi
            z[i] = zi
            sx += xi
            sy += yi
            sz += zi
            sxx += xi * xi
            sxy += xi * yi
            syy += yi * yi
            sxz += xi * zi
            syz += yi * zi
            szz += zi * zi
        det, inverse = plane_inverse(n, sx, sy, sxx, sxy, syy)
        if not det > 0.0:
            continue  # the points lie on a line
        i00, i01, i02, i11, i12, i22 = inverse
        a0 = i00 * sz + i01 * sxz + i02 * syz
        b0 = i01 * sz + i11 * sxz + i12 * syz
        c0 = i02 * sz + i12 * sxz + i22 * syz
        slope = math.hypot(b0, c0)
        if slope == 0.0:
            continue
        s = (x * b0 + y * c0) / slope
        buckets = max(n // 4, 16)
        bucketed = np.empty(n)
        offsets = np.empty(buckets + 1, dtype=np.int64)
        done = np.empty(buckets, dtype=np.bool_)
        _bucket_values(s, bucketed, offsets, done)
        for k in range(splits_n):
            splits[k] = _bucketed_quantile(bucketed, offsets, done, quantiles[k])
        rise = slope * (splits[splits_n - 1] - splits[0])  # over the central quantiles [m]
        runs[:] = 0.0
        for i in range(n):
            run = np.searchsorted(splits, s[i], side="left")  # splits strictly below s[i]
            runs[run, 0] += 1.0
            runs[run, 1] += x[i]
            runs[run, 2] += y[i]
            runs[run, 3] += z[i]
        sums_beyond(runs, beyond)
        for k in range(splits_n):
            m = int(beyond[k + 1, 0])  # the runs beyond split k
            if m <= 0 or m >= n:
                continue
            delta, t, (_, w1, w2) = plane_step(
                inverse,
                (a0, b0, c0),
                (sz, sxz, syz, szz),
                (beyond[k + 1, 0], beyond[k + 1, 1], beyond[k + 1, 2], beyond[k + 1, 3]),
                n,
                correlation,
            )
            turn = abs(delta) * math.hypot(w1, w2)  # the slope's change [rad], small angles
            if t > max_step_t and turn > min_turn_rad and abs(delta) >= 0.5 * rise:
                stepped[p] = True
                break
    return stepped
