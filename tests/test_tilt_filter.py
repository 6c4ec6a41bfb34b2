"""The camera tilt filter (`mapper.tilt_filter`): gains, steady-state error, steps, application."""

import math

import numpy as np
import pytest
from synthetic_depth import look_down_camera, render_boxes

from mapper.errors import InvalidParameterError
from mapper.intrinsics import PinholeIntrinsics
from mapper.segmentation import SegmentationParams, segment_depth
from mapper.tilt_filter import (
    TiltFilter,
    TiltFilterParams,
    apply_tilt,
    measured_tilt,
    steady_state,
)

DEG = math.pi / 180.0

# Hand-computed case (deg², per axis): σ_w = 0.3, σ = 0.4, R = σ_w² + σ² = 0.25. A process
# variance q = 0.125 gives P⁻ = (q + sqrt(q² + 4qR))/2 = (0.125 + 0.375)/2 = 0.25, so
# Kb = P⁻/(P⁻ + R) = 0.5, Kx = (P⁻ + σ_w²)/(P⁻ + R) = 0.34/0.5 = 0.68 and
# σ_x = sqrt(0.34·0.16/0.5) = sqrt(0.1088) = 0.329848°. sqrt(q) = 0.353553° = bias_deg·turn
# with bias_deg = 4: turn = 0.0883883 rad per frame.
NOISE_DEG, SIGMA_DEG, BIAS_DEG = 0.3, 0.4, 4.0
TURN_RAD = math.sqrt(0.125) / BIAS_DEG


def test_steady_state_gains_are_the_hand_computed_ones():
    kx, kb, sigma_x = steady_state(NOISE_DEG * DEG, SIGMA_DEG * DEG, BIAS_DEG * DEG * TURN_RAD)
    assert kx == pytest.approx(0.68, rel=1e-12)
    assert kb == pytest.approx(0.5, rel=1e-12)
    assert sigma_x / DEG == pytest.approx(math.sqrt(0.1088), rel=1e-12)


def test_constant_bias_with_white_noise_is_estimated_within_its_steady_state_sigma():
    # No turn: the bias is constant, its estimate converges (P ~ R/k), and the estimate of the
    # frame's tilt b + w takes Kx = σ_w²/(σ_w² + σ²) = 0.5 of the measurement when σ = σ_w:
    # σ_x = σ/√2 = 0.212132° (hand), against 0.3° for the raw measurement and for b alone.
    rng = np.random.default_rng(12)
    bias = np.array([2.5, -0.9]) * DEG
    tilt_filter = TiltFilter(TiltFilterParams(noise_deg=0.3, bias_deg=4.0))
    errors = []
    for k in range(4100):
        truth = bias + rng.normal(0.0, 0.3 * DEG, 2)
        measured = truth + rng.normal(0.0, 0.3 * DEG, 2)
        estimate = tilt_filter.update(measured, 0.3 * DEG, 0.0)
        if k >= 100:
            errors.append(estimate.tilt_rad - truth)
    rms_deg = float(np.sqrt(np.mean(np.square(errors)))) / DEG
    sigma_x_deg = 0.3 / math.sqrt(2.0)
    # 8000 samples: the RMS's relative standard error is 1/sqrt(16000) = 0.8 %; allow 3 of them.
    assert rms_deg <= sigma_x_deg * 1.024
    assert rms_deg >= sigma_x_deg * 0.976  # and it is that error, not a smaller one by luck
    assert estimate.sigma_rad / DEG == pytest.approx(sigma_x_deg, rel=0.01)


def _steady_filter(tilt_rad, reset_refusals=5):
    """A filter at steady state on noise-free measurements ``tilt_rad`` (hand case above)."""
    params = TiltFilterParams(noise_deg=NOISE_DEG, bias_deg=BIAS_DEG, reset_refusals=reset_refusals)
    tilt_filter = TiltFilter(params)
    for _ in range(200):
        tilt_filter.update(tilt_rad, SIGMA_DEG * DEG, TURN_RAD)
    return tilt_filter


def test_a_bias_step_is_followed_at_the_hand_computed_rate():
    # Noise-free data from a filter at steady state (turning 0.088 rad per frame): after a step
    # of Δ = 2° in the bias, the estimate's error at the j-th frame from the step is
    # -(1 - Kx)·Δ·(1 - Kb)^j = -0.64°·0.5^j (hand gains above): within σ_x = 0.33° from j = 1
    # (0.32°), not at j = 0 (0.64°). The step's innovation passes the gate: 2²/(P⁻ + R) = 8.
    before = np.array([1.0, -2.0]) * DEG
    tilt_filter = _steady_filter(before)
    step = np.array([2.0, 0.0]) * DEG
    errors_deg = []
    for _ in range(6):
        estimate = tilt_filter.update(before + step, SIGMA_DEG * DEG, TURN_RAD)
        assert estimate.measured
        errors_deg.append((estimate.tilt_rad - before - step) / DEG)
    np.testing.assert_allclose([e[0] for e in errors_deg], [-0.64 * 0.5**j for j in range(6)])
    np.testing.assert_allclose([e[1] for e in errors_deg], 0.0, atol=1e-12)
    within = [abs(e[0]) <= math.sqrt(0.1088) for e in errors_deg]
    assert within == [False, True, True, True, True, True]


def test_the_gate_refuses_an_improbable_measurement_until_the_bias_is_uncertain_enough():
    # Steady state: P⁻ + R = 0.5 deg². An innovation of 2.5° (12.5 < 13.82) is used, one of 3°
    # (18) is refused: the frame takes b̂⁻. A lasting 4° step (32) is refused while
    # 16/(0.5 + 0.125·j) > 13.8155 (P⁻ grows by q = 0.125 deg² per refused frame), i.e. for
    # j = 0..5 (j = 5: 16/1.125 = 14.2), and used at j = 6 (16/1.25 = 12.8) — the gate alone,
    # without the re-start after agreeing refusals (next tests).
    before = np.array([1.0, -2.0]) * DEG
    accepted = _steady_filter(before).update(
        before + np.array([0.0, 2.5]) * DEG, SIGMA_DEG * DEG, TURN_RAD
    )
    assert accepted.measured
    tilt_filter = _steady_filter(before)
    refused = tilt_filter.update(before + np.array([0.0, 3.0]) * DEG, SIGMA_DEG * DEG, TURN_RAD)
    assert not refused.measured
    np.testing.assert_allclose(refused.tilt_rad, before, rtol=1e-12)
    tilt_filter = _steady_filter(before, reset_refusals=0)
    used = [
        tilt_filter.update(before + np.array([4.0, 0.0]) * DEG, SIGMA_DEG * DEG, TURN_RAD).measured
        for _ in range(8)
    ]
    assert used == [False] * 6 + [True, True]


def test_agreeing_refusals_restart_the_filter_from_their_weighted_mean():
    # A gross error accepted under the wide prior (the first frame measures 13.9°, prior 4°:
    # 13.9²/(16 + 0.09 + 0.0625) = 11.96 < 13.82) locks the bias: the right measurements
    # (0°) are refused. The fifth refused in a row re-starts the filter from the five: bias =
    # their weighted mean, variance 1/Σ(1/R_i) (R_i = σ_w² + σ_i²), and is taken as measured.
    tilt_filter = TiltFilter(TiltFilterParams(noise_deg=0.3, bias_deg=4.0))
    assert tilt_filter.update(np.array([13.9, 0.0]) * DEG, 0.25 * DEG, 0.0).measured
    values_deg = [0.1, -0.2, 0.05, 0.0, 0.15]
    sigmas_deg = [0.2, 0.25, 0.2, 0.3, 0.25]
    used = [
        tilt_filter.update(np.array([x, -x]) * DEG, s * DEG, 0.0).measured
        for x, s in zip(values_deg, sigmas_deg, strict=True)
    ]
    assert used == [False, False, False, False, True]
    assert tilt_filter.restarts == 1
    weights = np.array([1.0 / (0.09 + s**2) for s in sigmas_deg])  # 1/deg²
    mean_deg = weights @ np.array(values_deg) / weights.sum()
    np.testing.assert_allclose(tilt_filter.bias_rad, np.array([mean_deg, -mean_deg]) * DEG)
    assert tilt_filter.bias_var == pytest.approx(DEG**2 / weights.sum(), rel=1e-12)
    # From then on the right measurements pass the gate.
    assert tilt_filter.update(np.array([0.1, 0.0]) * DEG, 0.2 * DEG, 0.0).measured


def test_refusals_that_disagree_or_are_broken_by_an_accepted_one_do_not_restart():
    # Gross errors scattered ±8° (a different wrong plane each time) never agree.
    tilt_filter = _steady_filter(np.zeros(2))
    for x in (8.0, -8.0, 8.0, -8.0, 8.0, -8.0, 8.0):
        assert not tilt_filter.update(np.array([x, 0.0]) * DEG, 0.2 * DEG, 0.0).measured
    assert tilt_filter.restarts == 0
    np.testing.assert_allclose(tilt_filter.bias_rad, 0.0, atol=1e-15)
    # Four agreeing refusals, an accepted frame, four more: no re-start (the row is broken).
    tilt_filter = TiltFilter(TiltFilterParams(noise_deg=0.3, bias_deg=4.0))
    for _ in range(50):
        tilt_filter.update(np.zeros(2), 0.2 * DEG, 0.0)
    for accepted in ([False] * 4 + [True]) * 2:
        z = np.zeros(2) if accepted else np.array([6.0, 0.0]) * DEG
        assert tilt_filter.update(z, 0.2 * DEG, 0.0).measured == accepted
    assert tilt_filter.restarts == 0
    # Frames without a measurement do not break the row: in a filter that has used one
    # measurement (a narrow prior, 0.5°: 6° is refused), the fifth agreeing one re-starts.
    tilt_filter = TiltFilter(TiltFilterParams(noise_deg=0.3, bias_deg=0.5))
    assert tilt_filter.update(np.zeros(2), 0.2 * DEG, 0.0).measured
    for _ in range(4):
        assert not tilt_filter.update(np.array([6.0, 0.0]) * DEG, 0.2 * DEG, 0.0).measured
        tilt_filter.update(None, math.inf, 0.0)
    assert tilt_filter.update(np.array([6.0, 0.0]) * DEG, 0.2 * DEG, 0.0).measured
    assert tilt_filter.restarts == 1


def test_agreeing_refusals_restart_only_once_they_outnumber_the_measurements_used():
    # A filter that has followed the camera for 50 measurements (0°) refuses a run of agreeing
    # wrong ones (6°: talos_course stereo seed 6, five frames measuring the ground strips
    # between the threshold, sill and step_1 about 3° off while the bias was right): it
    # re-starts only when the row is longer than the 50 it used, at the 51st.
    tilt_filter = TiltFilter(TiltFilterParams(noise_deg=0.3, bias_deg=4.0))
    for _ in range(50):
        assert tilt_filter.update(np.zeros(2), 0.2 * DEG, 0.0).measured
    used = [
        tilt_filter.update(np.array([6.0, 0.0]) * DEG, 0.2 * DEG, 0.0).measured for _ in range(51)
    ]
    assert used == [False] * 50 + [True]
    assert tilt_filter.restarts == 1
    np.testing.assert_allclose(tilt_filter.bias_rad, np.array([6.0, 0.0]) * DEG, rtol=1e-12)
    # After the re-start the count begins anew: 0 used, so five agreeing refusals re-start.
    for _ in range(4):
        assert not tilt_filter.update(np.zeros(2), 0.2 * DEG, 0.0).measured
    assert tilt_filter.update(np.zeros(2), 0.2 * DEG, 0.0).measured
    assert tilt_filter.restarts == 2


def test_a_frame_without_a_measurement_takes_the_bias_estimate_and_loses_certainty():
    tilt_filter = TiltFilter(TiltFilterParams(noise_deg=0.3, bias_deg=4.0))
    for _ in range(50):
        tilt_filter.update(np.array([0.02, 0.01]), 0.3 * DEG, 0.0)
    bias, var = tilt_filter.bias_rad.copy(), tilt_filter.bias_var
    estimate = tilt_filter.update(None, math.inf, 0.1)
    np.testing.assert_array_equal(estimate.tilt_rad, bias)
    # Var(x) = P + q + σ_w², q = (4° · 0.1)².
    expected = var + (4.0 * DEG * 0.1) ** 2
    assert tilt_filter.bias_var == pytest.approx(expected, rel=1e-12)
    assert estimate.sigma_rad == pytest.approx(np.sqrt(expected + (0.3 * DEG) ** 2), rel=1e-12)


@pytest.mark.parametrize(
    ("name", "value"),
    [
        ("noise_deg", -0.1),
        ("bias_deg", math.inf),
        ("gate_chi2", 0.0),
        ("reset_refusals", -1),
        ("reset_refusals", 2.0),
        ("reset_refusals", True),
        ("tail_dof", 0.0),
        ("tail_dof", -2.0),
    ],
)
def test_params_refuse_negative_or_infinite_levels_naming_the_field(name, value):
    with pytest.raises(InvalidParameterError, match=f"TiltFilterParams.{name}"):
        TiltFilterParams(**{name: value})


INTR = PinholeIntrinsics.from_fov(88, 72, 47.0, 39.0)


def _tilted(transform, angle_deg):
    """``transform`` turned about the robot's x axis through the camera centre."""
    c, s = math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg))
    out = transform.copy()
    out[:3, :3] = np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]]) @ transform[:3, :3]
    return out


def test_the_measured_tilt_is_the_believed_pose_s_error_and_applying_the_truth_levels_the_ground():
    # Exact ground seen by a camera at 0.9 m looking 35° down; the robot believes it 2° off
    # about x. The measured tilt is the ground normal in the believed frame: (0, -sin 2°)
    # (the believed rotation Rx(2°) turns the true up vector (0, 0, 1) to (0, -sin 2°, cos 2°)).
    true = look_down_camera((0.0, 0.0, 0.9), pitch_down_deg=35.0)
    believed = _tilted(true, 2.0)
    depth = render_boxes(INTR, true, [])
    params = SegmentationParams(correct_ground_shift=False)
    result = segment_depth(depth, INTR, believed, params)
    measured, sigma = measured_tilt(result, params)
    assert measured is not None
    np.testing.assert_allclose(measured, [0.0, -math.sin(math.radians(2.0))], atol=1e-6)
    assert sigma.shape == (2,) and 0.0 < sigma[1] < 1e-3
    assert sigma[0] == sigma[1]  # tilt_pitch_sigma_factor 1: the fit's std on both axes
    doubled = SegmentationParams(correct_ground_shift=False, tilt_pitch_sigma_factor=2.0)
    _, sigma_doubled = measured_tilt(segment_depth(depth, INTR, believed, doubled), doubled)
    np.testing.assert_array_equal(sigma_doubled, [2.0 * sigma[1], sigma[1]])
    # Applying a 1° tilt instead: the ground tilts by the remaining 1° about the camera centre.
    half = apply_tilt(result, np.array([0.0, -math.sin(math.radians(1.0))]))
    np.testing.assert_allclose(
        half.transform_camera_to_robot[:3, :3], _tilted(true, 1.0)[:3, :3], atol=1e-6
    )
    floor = np.isfinite(half.floor_heights)
    assert floor.mean() > 0.9
    # One region, one height: its points' mean z (the tilted ground's points spread about it).
    assert np.ptp(half.points[floor, 2]) > 0.02
    np.testing.assert_allclose(half.floor_heights[floor], half.points[floor, 2].mean(), atol=1e-9)
    np.testing.assert_allclose(half.floors.heights_m, [half.points[floor, 2].mean()], atol=1e-9)
    assert np.ptp(half.points[floor, 2]) > 0.01  # no longer level
    # And back to the measured one: the segmentation's own result.
    again = apply_tilt(half, measured)
    np.testing.assert_allclose(again.points, result.points, atol=1e-9)
    np.testing.assert_allclose(again.floor_heights, result.floor_heights, atol=1e-9)
    np.testing.assert_allclose(again.floors.heights_m, result.floors.heights_m, atol=1e-9)
    np.testing.assert_allclose(
        again.transform_camera_to_robot, result.transform_camera_to_robot, atol=1e-9
    )


def test_each_axis_takes_the_gain_of_its_own_measurement_variance():
    # One measurement, prior N(0, 4°²), σ_w = 0.3°; σ = (0.6°, 0.2°) per axis: each axis's gain
    # is Kx = (P + σ_w²) / (P + σ_w² + σ²) with its own σ (hand-computed here).
    tilt_filter = TiltFilter(TiltFilterParams(noise_deg=0.3, bias_deg=4.0))
    measured = np.array([0.5, -0.5]) * DEG
    sigma = np.array([0.6, 0.2]) * DEG
    estimate = tilt_filter.update(measured, sigma, 0.0)
    signal = (4.0**2 + 0.3**2) * DEG**2
    gains = signal / (signal + sigma**2)
    np.testing.assert_allclose(estimate.tilt_rad, gains * measured, rtol=1e-12)
    np.testing.assert_allclose(
        estimate.sigma_rad, np.sqrt(signal * sigma**2 / (signal + sigma**2)), rtol=1e-12
    )
    bias_gains = (4.0 * DEG) ** 2 / (signal + sigma**2)
    np.testing.assert_allclose(tilt_filter.bias_rad, bias_gains * measured, rtol=1e-12)
    assert estimate.tilt_rad[0] / measured[0] < estimate.tilt_rad[1] / measured[1]


def test_the_gate_weighs_each_axis_by_its_own_variance():
    # After the bias has settled at 0, an innovation of 1.5° on x is within the gate when x's
    # measurement is noisy (σ_x = 1°) and refused when it is as precise as y's (0.1°).
    def settled(sigma_x_deg: float) -> TiltFilter:
        tilt_filter = TiltFilter(TiltFilterParams(noise_deg=0.3, bias_deg=4.0))
        for _ in range(100):
            tilt_filter.update(np.zeros(2), np.array([sigma_x_deg, 0.1]) * DEG, 0.0)
        return tilt_filter

    jump = np.array([1.5, 0.0]) * DEG
    assert settled(1.0).update(jump, np.array([1.0, 0.1]) * DEG, 0.0).measured
    assert not settled(0.1).update(jump, np.array([0.1, 0.1]) * DEG, 0.0).measured


def test_tail_weight_is_the_hand_computed_one_when_the_prior_is_certain():
    # With no signal variance the estimate stays at the prior whatever λ, so the residual is
    # the innovation and λ = (dof + 1)/(dof + ν²/R) after one step: dof 4, ν²/R = 9 → 5/13.
    from mapper.tilt_filter import _tail_weights

    variance = (0.4 * DEG) ** 2
    weights = _tail_weights(np.array([1.2, 0.0]) * DEG, np.zeros(2), np.full(2, variance), dof=4.0)
    np.testing.assert_allclose(weights, [5.0 / 13.0, 5.0 / 4.0], rtol=1e-12)


def test_tail_weights_solve_their_fixed_point_equation():
    from mapper.tilt_filter import _tail_weights

    innovation = np.array([1.5, -0.4]) * DEG
    signal = np.full(2, (0.3**2 + 0.1**2) * DEG**2)
    measurement = np.array([0.5, 0.2]) ** 2 * DEG**2
    dof = 2.0
    weights = _tail_weights(innovation, signal, measurement, dof, iterations=50)
    effective = measurement / weights
    total = signal + effective
    expected = (dof + 1.0) / (
        dof + ((innovation * effective / total) ** 2 + signal * effective / total) / measurement
    )
    np.testing.assert_allclose(weights, expected, rtol=1e-9)
    # Five iterations (the filter's) are within 1e-3 of the fixed point.
    np.testing.assert_allclose(
        _tail_weights(innovation, signal, measurement, dof), weights, rtol=1e-3
    )


def _settled(params: TiltFilterParams, sigma_deg: float) -> TiltFilter:
    tilt_filter = TiltFilter(params)
    for _ in range(100):
        tilt_filter.update(np.zeros(2), np.full(2, sigma_deg * DEG), 0.0)
    return tilt_filter


def test_a_heavy_tailed_filter_takes_an_outlying_noisy_pitch_at_a_lower_gain():
    # Stereo-like σ = 0.5°: a 1.5° innovation (inside the gate) is applied at the Gaussian
    # gain by default and at less than half of it with tail_dof = 2 (0.157° against 0.408°);
    # a 0.1° one at a little more than the Gaussian gain (λ > 1 for a residual below σ).
    big = np.array([1.5, 0.0]) * DEG
    gaussian = _settled(TiltFilterParams(), 0.5).update(big, np.full(2, 0.5 * DEG), 0.0)
    heavy = _settled(TiltFilterParams(tail_dof=2.0), 0.5).update(big, np.full(2, 0.5 * DEG), 0.0)
    assert gaussian.measured and heavy.measured
    assert heavy.tilt_rad[0] < 0.5 * gaussian.tilt_rad[0]
    small = np.array([0.1, 0.0]) * DEG
    gaussian = _settled(TiltFilterParams(), 0.5).update(small, np.full(2, 0.5 * DEG), 0.0)
    heavy = _settled(TiltFilterParams(tail_dof=2.0), 0.5).update(small, np.full(2, 0.5 * DEG), 0.0)
    assert gaussian.tilt_rad[0] < heavy.tilt_rad[0] < 1.5 * gaussian.tilt_rad[0]


def test_a_heavy_tailed_filter_takes_a_precise_measurement_as_the_gaussian_one_does():
    # Depth-like σ = 0.02° far below σ_w = 0.3°: a 1° innovation is the frame's real tilt
    # (encoder noise), not a measurement error; λ stays ~1 and the gain is the Gaussian one.
    jump = np.array([1.0, -0.5]) * DEG
    sigma = np.full(2, 0.02 * DEG)
    gaussian = _settled(TiltFilterParams(), 0.02).update(jump, sigma, 0.0)
    heavy = _settled(TiltFilterParams(tail_dof=2.0), 0.02).update(jump, sigma, 0.0)
    np.testing.assert_allclose(heavy.tilt_rad, gaussian.tilt_rad, rtol=1e-3)
