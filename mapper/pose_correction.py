"""The pose correction of a segmented depth image: tilt rotation and ground-plane z shift.

The paper (Sec. IV) absorbs camera rotation errors of the joint encoders by rotating the range
data "according to the direction of planes that are approximately horizontal", and searches "for
the plane that is closest to an expected ground plane, and, if found, shifts all data points
accordingly". `segment_depth` fits the planes; this module decides the correction from the
per-plane table (normals, heights, areas) in the robot frame R (z up, origin on the ground below
the robot).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mapper import tilt_kernels

__all__ = [
    "PoseCorrection",
    "estimate_tilt",
    "ground_shift",
    "rotation_to_vertical",
    "stepped_planes",
    "within_deg_of_vertical",
]

STEP_SPLITS = 17
"""Split positions `stepped_planes` tries: quantiles 0.1, 0.15, ..., 0.9 of the points along the
plane's downhill direction (each side keeps at least a tenth of the plane's points)."""
STEP_QUANTILES = np.linspace(0.1, 0.9, STEP_SPLITS)
"""The `STEP_SPLITS` quantiles (made once: ``np.linspace`` costs 30 µs a frame)."""


@dataclass(frozen=True)
class PoseCorrection:
    """The correction `segment_depth` applied to the believed robot-frame data.

    Corrected point = pivot + rotation·(point − pivot) + (0, 0, z_shift_m).

    Attributes:
        rotation: 3×3 rotation (tilt only, no yaw component beyond the minimal rotation).
        pivot_m: (3,) rotation centre [m], the believed camera centre in the robot frame.
        z_shift_m: shift added to z after the rotation [m] (0 if no ground plane was found).
        ground_plane_found: a floor plane was found within the ground search window.
        tilt_planes: how many near-horizontal planes steered the rotation (0: none applied).
    """

    rotation: NDArray[np.float64]
    pivot_m: NDArray[np.float64]
    z_shift_m: float
    ground_plane_found: bool
    tilt_planes: int

    @property
    def rotation_deg(self) -> float:
        """Angle of the rotation [deg]."""
        c = (np.trace(self.rotation) - 1.0) / 2.0
        return math.degrees(math.acos(min(1.0, max(-1.0, c))))

    @property
    def transform(self) -> NDArray[np.float64]:
        """4×4 map from believed robot-frame points to corrected ones."""
        out = np.eye(4)
        out[:3, :3] = self.rotation
        out[:3, 3] = self.pivot_m - self.rotation @ self.pivot_m
        out[2, 3] += self.z_shift_m
        return out

    @staticmethod
    def identity(pivot_m: NDArray[np.float64]) -> PoseCorrection:
        """No correction."""
        return PoseCorrection(np.eye(3), np.asarray(pivot_m, dtype=np.float64), 0.0, False, 0)


def within_deg_of_vertical(normals: NDArray[np.float64], angle_deg: float) -> NDArray[np.bool_]:
    """Unit normals (P, 3) within ``angle_deg`` of ±z."""
    return np.abs(normals[:, 2]) >= math.cos(math.radians(angle_deg))


def estimate_tilt(normals, areas, eigen, counts, pivot, params) -> PoseCorrection:
    """Rotation that makes the near-horizontal planes' mean normal vertical.

    Candidates: planes large enough to be floor whose normal is within
    `max_tilt_correction_deg` of vertical. The reference is the candidate whose consensus (the
    candidates whose normal agrees with it within `tilt_consensus_deg`) has the largest total
    area, so one large ramp or slanted top cannot outvote the horizontal planes agreeing with
    each other; the consensus is averaged, weighted by footprint area (small, noisy or
    contaminated planes barely count).
    """
    if not params.correct_tilt or normals.shape[0] == 0:
        return PoseCorrection.identity(pivot)
    max_tilt_cos = math.cos(math.radians(params.max_tilt_correction_deg))
    candidates, agree, n_candidates = tilt_kernels.tilt_candidates(
        normals,
        normals @ normals.T,
        eigen,
        counts,
        max_tilt_cos,
        math.cos(math.radians(params.tilt_consensus_deg)),
        params.min_plane_pixels,
        params.min_plane_extent_m,
    )
    if n_candidates == 0:
        return PoseCorrection.identity(pivot)
    # The two products stay numpy's (BLAS): their float order is the kernels' reference.
    mean, n_planes, within = tilt_kernels.tilt_consensus(
        normals, areas, candidates, agree, agree @ areas, max_tilt_cos
    )
    if not within:
        return PoseCorrection.identity(pivot)
    return PoseCorrection(
        rotation=rotation_to_vertical(mean),
        pivot_m=pivot,
        z_shift_m=0.0,
        ground_plane_found=False,
        tilt_planes=n_planes,
    )


def ground_shift(correction, heights, areas, is_floor, params) -> PoseCorrection:
    """Shift so the floor plane nearest the expected ground plane lies on it.

    Only floor planes within `ground_search_window_m` of `expected_ground_z_m` and with at
    least a quarter of the largest such plane's area compete (a sliver of ground next to a
    step must not outvote the ground itself).
    """
    found, offset = tilt_kernels.ground_level(
        heights, areas, is_floor, params.expected_ground_z_m, params.ground_search_window_m
    )
    if not found:
        return correction
    shift = -offset if params.correct_ground_shift else 0.0
    return PoseCorrection(
        correction.rotation, correction.pivot_m, shift, True, correction.tilt_planes
    )


def rotation_to_vertical(normal: NDArray[np.float64]) -> NDArray[np.float64]:
    """Smallest rotation taking the unit vector ``normal`` (z > 0) to +z (Rodrigues)."""
    nx, ny, nz = (float(v) for v in normal)
    s = math.hypot(nx, ny)  # sin of the angle; axis = normal × z = (ny, -nx, 0) / s
    if s < 1e-12:
        return np.eye(3)
    kx, ky = ny / s, -nx / s
    one_c = 1.0 - nz
    return np.array(
        [
            [1.0 - one_c * ky * ky, one_c * kx * ky, s * ky],
            [one_c * kx * ky, 1.0 - one_c * kx * kx, -s * kx],
            [-s * ky, s * kx, nz],
        ]
    )


def stepped_planes(
    points: NDArray[np.float64],
    plane_ids: NDArray[np.int64],
    normals: NDArray[np.float64],
    counts: NDArray[np.int64],
    min_pixels: int,
    min_abs_z: float,
    max_step_t: float,
    correlation: float,
    min_turn_rad: float,
) -> NDArray[np.bool_]:
    """The near-horizontal planes whose points are two parallel levels joined, not one plane.

    A stereo matcher's noise and its window can hide a step of a few centimetres: a row does not
    split there, and one plane grows over a tread and the ground beside it, tilted by the step
    over its width (`simulated_world` stereo seed 2, frames 23-28: planes of 1300-2000 pixels
    half level_1's top, half the ground past its side edge 60 mm below, 3.5-3.9° off vertical,
    whose normals outweighed the ground's in the tilt consensus). Such a plane fits better as
    the same plane with a step across its downhill direction: per plane, in the frame of
    ``points`` (the believed robot frame, z up), the least-squares fit of
    ``z = a + b·x + c·y`` gives the downhill direction ``(b, c)``; the model with a step
    ``z = a + b·x + c·y + Δ·[s > s₀]`` (``s`` along that direction, ``s₀`` each of
    `STEP_SPLITS` quantiles) is fitted too, and the plane is *stepped* when the step's
    t-statistic ``|Δ| / sqrt(τ·σ²·(BᵀB)⁻¹_ΔΔ)`` (σ² the residual variance of the step model,
    τ = ``correlation``, correlated noise) exceeds ``max_step_t`` at some ``s₀`` where the step
    makes the plane's tilt: the step model's slope differs from the plane's by more than
    ``min_turn_rad``, and ``|Δ|`` is at least half the plane's rise over its central 80 % along
    ``s``. A plane that really is tilted (the encoders' error) has no step (its residual is the
    same on both sides); a level one has no tilt to explain; on noise-free data a millimetre's
    artefact scores a large t but turns nothing (a rendered box on the ground with a 15° pitch
    error is still corrected by 15°). On the frames above the joined planes score t 9.5-46
    (Δ 41-54 mm), every other plane at most 4.4.

    Args:
        points: (N, 3) the valid pixels' points [m], z up (believed robot frame).
        plane_ids: (N,) plane of each point (-1 none).
        normals: (P, 3) the planes' unit normals in that frame.
        counts: (P,) their pixels.
        min_pixels: planes with fewer pixels are not tested (not tilt candidates).
        min_abs_z: cos of the largest tilt tested (``max_tilt_correction_deg``).
        max_step_t: the step's t-statistic above which a plane is stepped (0: none is).
        correlation: ``noise_correlation_factor`` (τ ≥ 1).
        min_turn_rad: the least change of slope the step must make [rad] (small angles).

    Returns:
        (P,) bool: stepped planes.
    """
    n_planes = normals.shape[0]
    stepped = np.zeros(n_planes, dtype=np.bool_)
    if max_step_t <= 0.0 or n_planes == 0:
        return stepped
    tested = (np.abs(normals[:, 2]) >= min_abs_z) & (counts >= max(min_pixels, 8))
    if not tested.any():
        return stepped
    return tilt_kernels.stepped_plane_flags(
        np.ascontiguousarray(points, dtype=np.float64),
        np.ascontiguousarray(plane_ids, dtype=np.int64),
        tested,
        STEP_QUANTILES,
        float(max_step_t),
        float(correlation),
        float(min_turn_rad),
    )
