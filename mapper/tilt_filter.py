"""Temporal filter of the camera tilt the segmentation measures (beyond the paper).

The paper (Sec. IV) rotates every frame by the tilt its own near-horizontal planes give. That
measurement carries the plane fit's noise (stereo: about 0.2° per axis, independent from frame
to frame), and at 2 m a 0.2° rotation moves a point by 7 mm in height. The quantity measured,
the camera's true tilt error in the believed robot frame, is

    x_k = b_k + w_k,

``b_k`` the neck encoders' per-run bias as the current neck pose turns it (slowly varying: it
changes only while the camera turns in the robot frame) and ``w_k`` the encoders' per-frame
reading noise (white, ``noise_deg`` per tilt axis). The measurement is ``z_k = x_k + v_k`` with
``v_k`` the fit's noise (white, ``σ_k`` per axis, predicted per frame from the plane fits).

A Kalman filter estimates ``b`` (random walk with per-frame variance ``(bias_deg·Δθ_k)²``,
``Δθ_k`` the believed camera rotation since the previous frame [rad]: each neck joint's bias
error turns with its axis, and no joint axis turns more than the camera). The applied estimate
is of ``x_k``, not ``b_k``: with the prior ``b ~ N(b̂⁻, P⁻)``

    x̂_k = b̂⁻ + Kx·(z_k − b̂⁻),  Kx = (P⁻ + σ_w²) / (P⁻ + σ_w² + σ_k²),
    Var(x̂_k − x_k) = (P⁻ + σ_w²)·σ_k² / (P⁻ + σ_w² + σ_k²)  (≤ σ_k², the raw measurement's),

so a precise measurement (depth camera, σ_k ≪ σ_w) is taken almost as it is, a noisy one is
pulled towards the bias estimate, and a frame without tilt planes takes ``b̂⁻``. The bias update
is ``b̂ = b̂⁻ + Kb·(z_k − b̂⁻)``, ``Kb = P⁻ / (P⁻ + σ_w² + σ_k²)``.

Validation gate: a measurement whose innovation is improbable under this model,
``|z_k − b̂⁻|² / (P⁻ + σ_w² + σ_k²)`` above ``gate_chi2`` (χ² with 2 degrees of freedom), is
not used: the frame takes ``b̂⁻`` as if it had measured nothing. The segmentation's tilt has
gross errors when a wrong plane wins its consensus (stage stereo seeds 4, 8: 1.5 % of the frames
more than 1° off, up to 15°); one such frame maps everything it sees tilted.

Re-start: while the prior is wide (the first frames) the gate lets such a gross error in, and
the bias locks onto it: every right measurement after it is refused (stereo, simulated_world
seed 5, no encoder error: frame 0 measured 13.9°, accepted under the 4° prior, then 41 right
measurements of about 0° refused and the whole map 0.35 m high; stairs seeds 3–5 and
talos_course seeds 5–6 in stereo alike). So ``reset_refusals`` measurements refused in a row
(frames without a measurement do not break the row) that agree with one another — each within
the gate of their weighted mean — re-start the filter from them: they say the camera's tilt is
elsewhere, consistently, and the bias estimate is the outlier. Only when the row is longer than
the run of measurements the filter used since its start or last re-start, though: a locked
filter has used few, while one that has followed the camera for a while meets rows of agreeing
wrong planes (stereo talos_course seed 6, frames 146-153 at x ≈ 1.4 m: the ground strips
between the threshold, the sill and step_1, each 0.24-0.3 m deep with its far and near rows
blended with the surfaces beside them, measured about 3° off in five frames; the re-start at
frame 154 took the filter there from the right tilt it had followed since frame 84, and step_1
and step_2, seen in the next 20 frames, went into the map 23 mm low).

The tilt is the ground normal's (x, y) in the believed robot frame R (small angles, rad); the
two axes are filtered independently, each with its own measurement variance: in stereo the
measured pitch (x) scatters more than its fit predicts
(`SegmentationParams.tilt_pitch_sigma_factor`).

Heavy tails (`TiltFilterParams.tail_dof`, off): the measurement noise may be taken as Student-t
instead of Gaussian; an accepted measurement then gets a weight ``λ`` on its precision from a
variational fixed point (`_tail_weights`), so that one far from the prior for its own ``σ`` is
pulled towards the bias estimate rather than applied at its Gaussian gain.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mapper.errors import InvalidParameterError
from mapper.pose_correction import PoseCorrection, rotation_to_vertical
from mapper.segmentation import FloorTable, SegmentationParams, SegmentationResult
from mapper.tilt_kernels import tilt_variances, turn_points

__all__ = [
    "TiltEstimate",
    "TiltFilter",
    "TiltFilterParams",
    "apply_tilt",
    "measured_tilt",
    "steady_state",
]


@dataclass(frozen=True)
class TiltFilterParams:
    """Noise levels of the camera's tilt error (the robot's encoders), per tilt axis.

    Attributes:
        noise_deg: Std of the per-frame (white) tilt error of the believed camera pose [deg].
            0.3: the stage scenarios' neck encoder noise (``head_noise_deg``), which maps one to
            one into the camera's tilt (measured on the stage stereo recordings, seeds 1, 4, 6,
            8: frame-to-frame differences of the true tilt error give 0.29-0.31° per axis).
        bias_deg: Std of the per-run encoder bias of the neck joints [deg]: the prior of the
            bias and, times the camera's turn per frame, its process noise. 4.0: the stage
            scenarios' ``head_bias_deg``.
        gate_chi2: Innovations beyond this normalised square (χ², 2 degrees of freedom) are
            refused. 13.8155 = −2·ln(0.001): a measurement the model explains is refused once
            in 1000 frames. inf: every measurement is used. Each axis gated alone as well
            (1 degree of freedom, 10.83 for the same 1 in 1000; a prototype, session 57,
            replays of the held-out stereo recordings, seeds 1–8): 394.88 → 535.50 unsafe
            cells in all, `down_shallow_steps` seed 8 61 → 723 (its start), rows 30 better /
            28 worse by 0.5 mm or more; not kept.
        reset_refusals: This many measurements refused in a row that agree with one another
            (each within the gate of their weighted mean, its variance ``σ_w² + σ_k²``)
            re-start the filter from them (module docstring); 0: never. 5: a gross error comes
            from one frame's wrong plane (1.5 % of the stage stereo frames), so five mutually
            consistent ones in a row are rare while the bias is right (they do happen: see
            the module docstring, hence the row must also outnumber), and a locked
            filter (simulated_world stereo seed 5: the right measurements refused from frame 1
            on) is freed after five frames, before the height reference (8 ground
            measurements) has converged on the tilted frames.
        tail_dof: Degrees of freedom of a Student-t measurement noise (`_tail_weights`): an
            accepted measurement far from the prior for its own ``σ`` has its variance
            inflated instead of being taken at its Gaussian gain. inf (the default): Gaussian,
            the update above. The stereo head's pitch errors have a heavy tail (talos_course
            stereo: 21 % of the frames more than 1° off, 10 % more than 2°,
            `bench/tilt_calibration.py`); depth mode is untouched (its ``σ``, 0.02°, is far
            below ``σ_w``, so ``λ`` stays 1: the applied tilt's RMS error on stage, room and
            talos_course depth seeds 1–8 is the same to 0.001°). With 2, the applied pitch's
            RMS error against the truth (`bench/tilt_filter_eval.py`, stereo seeds 1–8) goes
            0.280 → 0.258° on the stage, 0.895 → 0.856° on talos_course, 0.235 → 0.224° in
            `room`, but the maps do not follow it one way (session 40, stereo replays seeds
            1–8, unsafe cells mean (worst)): stairs 48.6 (122) → 39.9 (81), stage 2.25 (5) →
            1.38 (4), stage_down 3.75 (9) → 3.62 (8), simulated_world 1.62 (7) → 1.25 (7), but
            room 8.62 (13) → 10.9 (22), talos_course 51.5 (92) → 56.5 (119) and the zig-zag
            stage's worst Table I row 1.52 → 3.60 mm. So inf: what holds a stereo map is not
            the filter's tail (its largest errors are the first frames' wrong planes, accepted
            under the wide prior, and the heading).
    """

    noise_deg: float = 0.3
    bias_deg: float = 4.0
    gate_chi2: float = -2.0 * math.log(1e-3)
    reset_refusals: int = 5
    tail_dof: float = math.inf

    def __post_init__(self) -> None:
        for name in ("noise_deg", "bias_deg"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and 0.0 <= value < math.inf):
                raise InvalidParameterError(
                    f"TiltFilterParams.{name} must be a finite number >= 0 deg, got {value!r}"
                )
        if not (isinstance(self.gate_chi2, int | float) and self.gate_chi2 > 0.0):
            raise InvalidParameterError(
                f"TiltFilterParams.gate_chi2 must be a number > 0 (inf: no gate), "
                f"got {self.gate_chi2!r}"
            )
        if not (isinstance(self.tail_dof, int | float) and self.tail_dof > 0.0):
            raise InvalidParameterError(
                f"TiltFilterParams.tail_dof must be a number > 0 (inf: Gaussian measurement "
                f"noise), got {self.tail_dof!r}"
            )
        if isinstance(self.reset_refusals, bool) or not (
            isinstance(self.reset_refusals, int) and 0 <= self.reset_refusals <= 1000
        ):
            raise InvalidParameterError(
                f"TiltFilterParams.reset_refusals must be a whole number 0 (never) to 1000, "
                f"got {self.reset_refusals!r}"
            )


@dataclass(frozen=True)
class TiltEstimate:
    """The filter's output for one frame.

    Attributes:
        tilt_rad: (2,) estimated (x, y) of the ground normal in the believed robot frame.
        sigma_rad: (2,) its predicted std per axis [rad].
        measured: The frame's measurement was used (False: none, or refused by the gate).
    """

    tilt_rad: NDArray[np.float64]
    sigma_rad: NDArray[np.float64]
    measured: bool


class TiltFilter:
    """Kalman filter of the camera tilt over frames (module docstring); feed frames in order."""

    def __init__(self, params: TiltFilterParams | None = None) -> None:
        self.params = params or TiltFilterParams()
        self._noise_var = math.radians(self.params.noise_deg) ** 2
        self._bias_var = math.radians(self.params.bias_deg) ** 2
        self.bias_rad = np.zeros(2)
        self.bias_var = np.full(2, self._bias_var)  # per axis; the prior: b ~ N(0, bias_deg²)
        self.restarts = 0
        # The measurements refused in a row: (tilt (2,), its variance σ_w² + σ_k² (2,)).
        self._refused: list[tuple[NDArray[np.float64], NDArray[np.float64]]] = []
        self._accepted = 0  # measurements used since the start or the last re-start

    def update(
        self,
        measured_rad: NDArray[np.float64] | None,
        sigma_rad: float | NDArray[np.float64],
        turn_rad: float,
    ) -> TiltEstimate:
        """Filter one frame's measurement.

        Args:
            measured_rad: (2,) the frame's measured tilt, None when it measured none.
            sigma_rad: The measurement's std [rad]: one for both axes, or (2,) per axis
                (ignored without a measurement).
            turn_rad: Rotation angle of the believed camera pose in R since the previous frame.

        Returns:
            The estimate of this frame's tilt and its std (``b̂⁻`` without a measurement or
            when the gate refused it).
        """
        prior_var = self.bias_var + self._bias_var * turn_rad**2
        signal_var = prior_var + self._noise_var  # Var(x_k) given the past
        measurement_var = np.broadcast_to(np.asarray(sigma_rad, dtype=np.float64) ** 2, (2,))
        total_var = signal_var + measurement_var
        innovation = (
            None
            if measured_rad is None or not np.all(np.isfinite(measurement_var))
            else np.asarray(measured_rad, dtype=np.float64) - self.bias_rad
        )
        if innovation is None:
            self.bias_var = prior_var
            return TiltEstimate(self.bias_rad.copy(), np.sqrt(signal_var), measured=False)
        # χ² of the innovation over both axes, in units of the x axis's variance (the same
        # floats as ``innovation·innovation / total_var`` when the axes' variances are equal).
        scaled = innovation * (total_var[0] / total_var)
        if float(innovation @ scaled) > self.params.gate_chi2 * total_var[0]:
            self._refused.append((self.bias_rad + innovation, self._noise_var + measurement_var))
            if not self._restart():
                self.bias_var = prior_var
                return TiltEstimate(self.bias_rad.copy(), np.sqrt(signal_var), measured=False)
            # Re-started from the refused measurements (this one among them): taken as measured.
            return TiltEstimate(self.bias_rad.copy(), np.sqrt(self.bias_var), measured=True)
        self._refused.clear()
        self._accepted += 1
        if self.params.tail_dof < math.inf:
            measurement_var = measurement_var / _tail_weights(
                innovation, signal_var, measurement_var, self.params.tail_dof
            )
            total_var = signal_var + measurement_var
        tilt = self.bias_rad + (signal_var / total_var) * innovation
        self.bias_rad = self.bias_rad + (prior_var / total_var) * innovation
        self.bias_var = prior_var * (1.0 - prior_var / total_var)
        return TiltEstimate(tilt, np.sqrt(signal_var * measurement_var / total_var), measured=True)

    def _restart(self) -> bool:
        """Re-start from the refused measurements if there are enough, they agree and outnumber.

        Enough: ``reset_refusals`` in a row. Outnumber: the row is longer than the run of
        measurements the filter used since its start or last re-start (a locked filter has used
        few; one that has followed the camera for a while is refusing a run of wrong planes).
        The bias becomes their inverse-variance weighted mean per axis, its variance
        ``1/Σ(1/R_i)`` (``R_i = σ_w² + σ_i²``: each measures ``b`` plus the frame's noise and
        the fit's).

        Returns:
            Whether it re-started (the refused measurements are then forgotten).
        """
        wanted = self.params.reset_refusals
        if wanted == 0 or len(self._refused) < wanted or len(self._refused) <= self._accepted:
            return False
        recent = self._refused[-wanted:]
        weights = np.array([1.0 / var for _, var in recent])  # (n, 2)
        values = np.array([value for value, _ in recent])
        mean = (weights * values).sum(axis=0) / weights.sum(axis=0)
        spread = ((values - mean) ** 2 * weights).sum(axis=1)
        if np.any(spread > self.params.gate_chi2):
            return False
        self.bias_rad = mean
        self.bias_var = 1.0 / weights.sum(axis=0)
        self._refused.clear()
        self._accepted = 0
        self.restarts += 1
        return True


def _tail_weights(
    innovation: NDArray[np.float64],
    signal_var: NDArray[np.float64],
    measurement_var: NDArray[np.float64],
    dof: float,
    iterations: int = 5,
) -> NDArray[np.float64]:
    """Per-axis weights ``λ`` of a Student-t measurement noise (variational Bayes).

    The measurement noise is ``v = sqrt(R/λ)·n`` with ``λ ~ Gamma(dof/2, dof/2)``; given the
    innovation ``ν``, ``λ`` and the tilt are estimated by fixed-point iteration: with ``R/λ``
    the measurement variance, the tilt estimate ``x̂ = b̂⁻ + Kx·ν`` and its variance ``Vx``,
    ``λ = (dof + 1) / (dof + ((1 − Kx)·ν)² / R + Vx / R)``. A measurement far from the
    prior relative to its own ``R`` gets ``λ < 1`` (its variance inflated); one whose
    ``R`` is small against the prior's (a depth camera) keeps ``λ ≈ 1``: its residual after
    the update, ``(1 − Kx)·ν``, is small whatever ``ν``.

    Args:
        innovation: (2,) ``z − b̂⁻`` [rad].
        signal_var: (2,) ``P⁻ + σ_w²`` [rad²].
        measurement_var: (2,) ``R`` [rad²], > 0.
        dof: Degrees of freedom of the noise's t distribution.
        iterations: Fixed-point iterations (5: converged to 1e-3 for |ν| up to 10√S).

    Returns:
        (2,) ``λ`` in ``(0, (dof + 1)/dof]``.
    """
    weight = np.ones_like(measurement_var)
    for _ in range(iterations):
        effective_var = measurement_var / weight
        total_var = signal_var + effective_var
        residual = innovation * (effective_var / total_var)
        estimate_var = signal_var * effective_var / total_var
        weight = (dof + 1.0) / (dof + (residual**2 + estimate_var) / measurement_var)
    return weight


def steady_state(
    noise_rad: float, sigma_rad: float, process_rad: float
) -> tuple[float, float, float]:
    """Steady-state gains and error of `TiltFilter` for constant noise levels.

    The prior variance solves ``P⁻ = P⁻·R/(P⁻ + R) + q`` (``R = σ_w² + σ²``, ``q`` the process
    variance): ``P⁻ = (q + sqrt(q² + 4qR)) / 2``.

    Args:
        noise_rad: σ_w, the per-frame tilt noise [rad].
        sigma_rad: σ, the measurement's std [rad].
        process_rad: sqrt(q), the bias's per-frame change [rad] (bias_deg·turn in rad).

    Returns:
        (Kx, Kb, σ_x): the applied gain, the bias gain and the applied estimate's error std.
    """
    q = process_rad**2
    r = noise_rad**2 + sigma_rad**2
    prior_var = 0.5 * (q + math.sqrt(q * q + 4.0 * q * r))
    total_var = prior_var + r
    signal_var = prior_var + noise_rad**2
    return (
        signal_var / total_var,
        prior_var / total_var,
        math.sqrt(signal_var * sigma_rad**2 / total_var),
    )


def measured_tilt(
    result: SegmentationResult, params: SegmentationParams
) -> tuple[NDArray[np.float64] | None, NDArray[np.float64] | float]:
    """The tilt a segmentation measured and its predicted std per axis [rad].

    The tilt is the (x, y) of the ground normal its correction took to vertical (believed robot
    frame). Its std is that of the consensus planes' weighted mean normal,
    ``1/sqrt(Σ 1/σ_p²)`` over the planes within ``tilt_consensus_deg`` of vertical after the
    correction that qualify as tilt candidates (`mapper.pose_correction.estimate_tilt`), per
    axis (÷√2). A plane's normal std comes from its fit: ``σ_p² = c·σ⊥²·12/n·(1/a² + 1/b²)``,
    ``σ⊥`` its RMS depth residual (at least ``min_noise_m``) projected on the normal along the
    ray to its centroid, ``n`` its pixels, ``a, b`` its in-plane extents, ``c`` the
    ``noise_correlation_factor``.

    The x axis's std (the pitch: the ground normal's forward component) is multiplied by
    ``tilt_pitch_sigma_factor``.

    Returns:
        (tilt, σ): σ (2,) per axis; tilt None and σ inf when the frame's correction used no
        plane.
    """
    correction = result.correction
    planes = result.planes
    if correction.tilt_planes == 0 or len(planes) == 0:
        return None, math.inf
    _, consensus, information = tilt_variances(
        result.points,
        result.plane_ids,
        planes.pixel_counts,
        correction.pivot_m,
        planes.normals,
        planes.rms_m,
        planes.extents_m,
        params.min_noise_m,
        params.noise_correlation_factor,
        params.min_plane_pixels,
        params.min_plane_extent_m,
        math.cos(math.radians(params.tilt_consensus_deg)),
    )
    if not consensus.any():
        return None, math.inf
    up = correction.rotation.T @ np.array([0.0, 0.0, 1.0])
    sigma = 1.0 / math.sqrt(information * 2.0)
    return up[:2].copy(), np.array([sigma * params.tilt_pitch_sigma_factor, sigma])


def apply_tilt(result: SegmentationResult, tilt_rad: NDArray[np.float64]) -> SegmentationResult:
    """``result`` with the tilt correction for ``tilt_rad`` instead of its own.

    The points, their floor heights, the floor regions' heights and the camera transform are
    turned about the correction's pivot (the camera centre) by ``R_new·R_ownᵀ``, the z shift
    kept: a floor region's height, and the floor height of each of its points, moves by its
    points' mean change (one height per region, as the segmentation gives it: per-point
    heights made every cell's set of floor heights distinct and the mapper's update 0.2 ms
    slower on the stage).
    """
    correction = result.correction
    tilt = np.asarray(tilt_rad, dtype=np.float64)
    normal = np.array([tilt[0], tilt[1], math.sqrt(max(1.0 - float(tilt @ tilt), 0.0))])
    rotation = rotation_to_vertical(normal)
    turn = rotation @ correction.rotation.T
    shift = np.array([0.0, 0.0, correction.z_shift_m])
    origin = correction.pivot_m + shift
    floors = result.floors
    points, floor_heights, region_dz = turn_points(
        result.points, result.floor_ids, result.floor_heights, turn, origin, len(floors)
    )
    step = np.eye(4)
    step[:3, :3] = turn
    step[:3, 3] = origin - turn @ origin
    # The dataclasses made directly: `dataclasses.replace` looks their fields up on every call.
    return SegmentationResult(
        points=points,
        floor_heights=floor_heights,
        plane_ids=result.plane_ids,
        floor_ids=result.floor_ids,
        pixel_index=result.pixel_index,
        correction=PoseCorrection(
            rotation,
            correction.pivot_m,
            correction.z_shift_m,
            correction.ground_plane_found,
            correction.tilt_planes,
        ),
        planes=result.planes,
        floors=FloorTable(
            pixel_counts=floors.pixel_counts,
            heights_m=floors.heights_m + region_dz,
            extents_m=floors.extents_m,
            areas_m2=floors.areas_m2,
            rms_ratio=floors.rms_ratio,
            is_floor=floors.is_floor,
        ),
        image_shape=result.image_shape,
        transform_camera_to_robot=step @ result.transform_camera_to_robot,
        structure_border=result.structure_border,
    )
