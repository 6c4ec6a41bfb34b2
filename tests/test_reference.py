"""The height reference over frames (mapper.reference): known answers on floor-region tables."""

import numpy as np
import pytest

from mapper.errors import InvalidParameterError
from mapper.reference import (
    HeightReference,
    HeightReferenceParams,
    arrival_drift_m,
    start_surface_m,
)

GROUND_AREA_M2 = 5.0  # the ground seen from the stage's camera covers 3-6 m²
TREAD_AREA_M2 = 0.2  # a stage tread: 0.2 m × 1 m


def feed(reference, heights, areas, floors=None, rise_m=0.0, prior_m=0.0):
    """One frame's floor regions (heights in the tilt-corrected robot frame, unshifted).

    ``rise_m``: odometry's z minus the start's (0: the robot stands at its start level).
    """
    heights = np.asarray(heights, dtype=np.float64)
    floors = np.ones(heights.shape, dtype=bool) if floors is None else np.asarray(floors)
    return reference.update(heights, np.asarray(areas, dtype=np.float64), floors, rise_m, prior_m)


def test_exact_data_give_exactly_zero_shift():
    reference = HeightReference()
    for _ in range(reference.params.min_frames):
        assert not reference.known
        assert feed(reference, [0.0, 0.031, 0.061], [GROUND_AREA_M2, 0.2, 0.2]) == 0.0
    assert reference.converged and reference.known
    assert reference.shift_m == 0.0


def test_the_shift_is_the_median_of_the_frames_ground_heights():
    # Camera believed 5.5 mm too low: the ground appears at -5.5 mm, scattered by ±4 mm.
    reference = HeightReference()
    heights = -0.0055 + np.array([0.004, -0.003, 0.001, -0.004, 0.0, 0.002, -0.001, 0.003])
    for h in heights:
        feed(reference, [h], [GROUND_AREA_M2])
    assert reference.shift_m == pytest.approx(float(np.median(-heights)), abs=1e-12)
    assert reference.shift_m == pytest.approx(0.0055 - 0.0005, abs=1e-12)


def test_one_wrong_frame_does_not_move_the_median():
    reference = HeightReference()
    for h in (-0.006, -0.006, 0.020, -0.006, -0.006):
        feed(reference, [h], [GROUND_AREA_M2])
    assert reference.shift_m == pytest.approx(0.006)


def test_the_largest_candidate_is_measured_not_the_fragment_nearest_the_prior():
    # Depth noise splits the ground into fragments millimetres apart (issue 11).
    reference = HeightReference()
    assert feed(reference, [-0.001, -0.009, -0.012], [0.4, 4.0, 0.35]) == pytest.approx(0.009)


def test_stairs_start_the_first_tread_alone_is_never_the_ground():
    # Camera 14 mm too low (the stage's worst seed): a 31 mm tread appears at +17 mm, inside
    # the gate; it is too small to be the ground around the robot.
    reference = HeightReference()
    for _ in range(20):
        assert feed(reference, [0.031 - 0.014], [TREAD_AREA_M2]) is None
    assert reference.shift_m == 0.0 and not reference.converged


def test_a_wide_tread_outside_the_gate_is_never_the_ground():
    # stage_zigzag's 0.28 m x 1.6 m treads (0.45 m²) are 45 mm high.
    reference = HeightReference()
    assert feed(reference, [0.045 - 0.014], [0.45]) is None


def test_descending_start_waits_then_measures_the_ground_under_the_feet():
    # On the platform: the ground 122 mm below and a sliver 22 mm up are in view, not the
    # platform. Nothing is measured; the data wait (not known) instead of taking either.
    reference = HeightReference(HeightReferenceParams(min_frames=3, max_wait_frames=0))
    for _ in range(50):
        assert feed(reference, [-0.126, 0.022, -0.096], [5.6, 0.05, 0.18]) is None
        assert not reference.known
    # Down on the ground: it lies under the feet, 4 mm low.
    for _ in range(3):
        assert feed(reference, [-0.004, 0.027], [4.0, 0.2]) == pytest.approx(0.004)
    assert reference.known and reference.shift_m == pytest.approx(0.004)


def test_walking_down_a_tread_taking_the_ground_below_for_its_own_is_outvoted():
    # Stereo, stage_down seed 5: on the first step (odometry 90 mm below the start) five frames
    # took the ground one rise below the feet (31 mm) for the ground under them: their noise
    # put it at -12 ... -20 mm, inside the gate. On the ground (121 mm below) the ground under
    # the feet appears at +4 mm (camera error -4 mm). Only the lowest level's measurements
    # count: the median of the first 8 measurements (+16 mm) is never the estimate.
    reference = HeightReference()
    for h in (-0.016, -0.012, -0.020, -0.012, -0.019):
        assert feed(reference, [h], [GROUND_AREA_M2], rise_m=-0.090) == pytest.approx(-h)
    assert reference.shift_m == pytest.approx(0.016)  # all it has seen, not converged
    ground = (0.004, 0.003, 0.006, 0.002, 0.005, 0.004, 0.001)
    for h in ground:
        feed(reference, [h], [GROUND_AREA_M2], rise_m=-0.121)
        assert not reference.known  # 5 + up to 7 measurements: 8 of them, but not 8 down here
    feed(reference, [0.004], [GROUND_AREA_M2], rise_m=-0.118)  # odometry's noise: same level
    assert reference.converged
    assert reference.shift_m == pytest.approx(-float(np.median((*ground, 0.004))))
    # Known once precise enough (`known_error_m`): the 8 scatter by ±3 mm (MAD 1 mm, standard
    # error 1.2533 · 1.4826 · 1 mm / √8 = 0.66 mm); two more at 4 mm make the MAD 0.5 mm
    # (0.29 mm).
    assert not reference.known
    for _ in range(2):
        feed(reference, [0.004], [GROUND_AREA_M2], rise_m=-0.121)
    assert reference.known and reference.shift_m == pytest.approx(-0.004)


def _walk_down_a_20_mm_step(reference, error_m=0.0):
    """The held-out `down_slant_turn` (depth, seed 8), camera ``error_m`` too high (its prior).

    From the 130 mm platform the first frames see the ground 130 mm below (5 m²) and the 20 mm
    step_1 tread 110 mm below (0.19 m²), both ``error_m`` lower. Twenty frames on step_1
    (odometry 110.8 mm below the start) see the ground 19.5 mm below the feet (seed 8: 20.7 mm,
    its prior 1.2 mm: inside the 20 mm gate around the prior either way); then frames on
    the ground (131.3 mm below) see it under the feet, 0.5 mm low. Returns the step's
    measurements and the estimate when the reference first became known (what the waiting
    frames are mapped with: the map's offset for the run).
    """
    for _ in range(10):
        feed(reference, [-0.130 - error_m, -0.110 - error_m], [5.0, 0.19], prior_m=error_m)
    on_step = []
    known_shift_m = None
    for rise_m, ground_m, frames in ((-0.1108, -0.0195, 20), (-0.1313, -0.0005, 8)):
        for _ in range(frames):
            measured = feed(reference, [ground_m - error_m], [4.2], rise_m=rise_m, prior_m=error_m)
            if rise_m > -0.12:
                on_step.append(measured)
            if reference.known and known_shift_m is None:
                known_shift_m = reference.shift_m
    return on_step, known_shift_m


@pytest.mark.parametrize("error_m", [0.0, 0.0126])
def test_on_a_tread_the_first_frames_saw_the_ground_below_is_not_measured(error_m):
    # The step's frames measure nothing (their feet stand on the tread the first frames saw);
    # the ground's frames make the estimate. With a camera 12.6 mm high (its prior; seed 2) the
    # levels are the prior's: on the ground the tread lies 19 mm above the feet, no tread.
    reference = HeightReference()
    on_step, known_shift_m = _walk_down_a_20_mm_step(reference, error_m)
    assert on_step == [None] * 20
    assert known_shift_m == pytest.approx(0.0005 + error_m)


def test_without_the_tread_rule_the_ground_below_a_low_step_is_taken():
    # The failure the rule was made for: known on the step with the ground below it as the
    # ground under the feet, every row 20 mm off (6681 unsafe cells on seed 8).
    reference = HeightReference(HeightReferenceParams(tread_min_area_m2=0.0))
    on_step, known_shift_m = _walk_down_a_20_mm_step(reference)
    assert on_step == [pytest.approx(0.0195)] * 20
    assert known_shift_m == pytest.approx(0.0195)


def test_on_a_patch_of_the_ground_taken_for_a_tread_the_ground_near_the_prior_is_measured():
    # Depth noise splits the ground: a 0.1 m² fragment 2 mm above it counts as a tread at the
    # feet's level once the robot stands on the ground (odometry 131 mm below). Its ground,
    # 1 mm from the prior, is measured; a region 15 mm from it (`tread_gate_m`: 10 mm) is not.
    reference = HeightReference()
    for _ in range(10):
        feed(reference, [-0.130, -0.128], [5.0, 0.1])
    assert feed(reference, [-0.001], [4.0], rise_m=-0.131) == pytest.approx(0.001)
    assert feed(reference, [-0.015], [4.0], rise_m=-0.131) is None
    # Off the tread's level (on the start level's ground) nothing changes.
    assert feed(HeightReference(), [-0.015], [4.0], rise_m=0.0) == pytest.approx(0.015)


def test_stereo_scatter_waits_for_a_precise_estimate_not_the_first_8_frames():
    # Walking down (stereo, stage_down seed 3): the camera is 6 mm too low, the ground under
    # the feet scatters by ±6 mm a frame, and the first 8 frames on the ground happened to see
    # it high: measurements 2, 3, 1, 4, 2, 9, 3, 5 mm, median 3 mm (the old reference, known
    # after 8, put every row 3 mm low). Their MAD is 1 mm: standard error
    # 1.2533 · 1.4826 · 1 mm / √8 = 0.66 mm > `known_error_m`, so the frames wait. Then the
    # measurements go round 6 mm + (-4, 4, -2, 2, 0, -6, 6, -1, 1, 0): after 56 in all the
    # median is 6 mm, the MAD 2 mm, the standard error 1.2533 · 1.4826 · 2 / √56 = 0.497 mm
    # (0.501 mm after 55).
    reference = HeightReference()
    first_mm = [2, 3, 1, 4, 2, 9, 3, 5]
    cycle_mm = [-4, 4, -2, 2, 0, -6, 6, -1, 1, 0]
    measured_mm = first_mm + [6 + c for _ in range(5) for c in cycle_mm]
    for count, value_mm in enumerate(measured_mm[:56], start=1):
        feed(reference, [-value_mm / 1000.0], [GROUND_AREA_M2], rise_m=-0.125)
        if count == 8:
            assert reference.converged and reference.shift_m == pytest.approx(0.003)
            assert reference.error_m == pytest.approx(1.2533 * 1.4826 * 0.001 / np.sqrt(8))
        if count == 55:
            assert not reference.known
    assert reference.known
    assert reference.shift_m == pytest.approx(0.006)
    assert reference.error_m == pytest.approx(1.2533 * 1.4826 * 0.002 / np.sqrt(56))


def test_at_the_start_level_min_frames_suffice_for_a_sensor_s_scatter():
    # Standing on the start surface, the map is anchored to the start pose's z (exact by the
    # kinematics), not to this estimate: the same first 8 frames as above make it known (their
    # standard error, 0.66 mm, is within `start_known_error_m`).
    reference = HeightReference()
    for value_mm in [2, 3, 1, 4, 2, 9, 3, 5]:
        assert not reference.known
        feed(reference, [-value_mm / 1000.0], [GROUND_AREA_M2], rise_m=-0.002)
    assert reference.error_m > reference.params.known_error_m
    assert reference.known and reference.shift_m == pytest.approx(0.003)


START_MISREAD_MM = [28.1, 25.1, 12.5, 19.2, 14.5, -14.8, -29.2, 16.5]


def test_at_the_start_level_frames_that_see_no_one_surface_wait():
    # Stereo on an 85 mm landing (down_shallow_steps seed 5): the first frames took the far
    # ground, misread 57-114 mm too high, for the ground under the feet. Median 15.5 mm;
    # quartiles (numpy's, linear) 5.675 and 20.675 mm: σ = 15 / 1.349 mm, standard error
    # 1.2533 · σ / √8 = 4.93 mm > `start_known_error_m` (3 mm): converged, not known (the
    # frames wait, as below the start level).
    reference = HeightReference()
    for value_mm in START_MISREAD_MM:
        feed(reference, [-value_mm / 1000.0], [GROUND_AREA_M2])
    assert reference.converged and reference.shift_m == pytest.approx(0.0155)
    assert reference.start_error_m == pytest.approx(1.2533 * 0.015 / 1.349 / np.sqrt(8))
    assert not reference.known
    off = HeightReference(HeightReferenceParams(start_known_error_m=float("inf")))
    for value_mm in START_MISREAD_MM:
        feed(off, [-value_mm / 1000.0], [GROUND_AREA_M2])
    assert off.known  # before session 45: 8 measurements at the start, whatever their scatter


def test_at_the_start_level_two_clusters_wait_with_the_wide_gate_and_settle_between_them():
    # A stereo start's views in two clusters, +-13 to 16 mm (tests/test_pipeline.py has the
    # frames). After 9 (5 at +13 … +16, 4 at -16 … -13) the MAD is one cluster's spread (a
    # standard error of 1.9 mm: it would settle on +13 mm); the interquartile range spans both
    # (29 mm: 9.6 mm), and the gate stays the start gate around the prior, so the other
    # cluster keeps being measured and the 16th measurement settles the median, 0.
    reference = HeightReference()
    values_mm = [15.0, -15.0, 14.0, -14.0, 16.0, -16.0, 13.0, -13.0] * 2
    for count, value_mm in enumerate(values_mm, start=1):
        assert feed(reference, [-value_mm / 1000.0], [GROUND_AREA_M2]) == pytest.approx(
            value_mm / 1000.0
        )
        assert reference.known == (count >= 16)
        if count == 9:
            assert reference.error_m < reference.params.start_known_error_m
            assert reference.start_error_m > reference.params.start_known_error_m
    assert reference.shift_m == pytest.approx(0.0, abs=1e-12)


def test_at_the_start_level_a_surface_measured_in_16_frames_settles_whatever_the_scatter():
    # Stereo on the stage's ground (seed 1): the first 8 frames measure -13.8 … 21.3 mm
    # (standard error 5.8 mm > 3 mm): they wait, but the ground under the feet is measured
    # again in the next frames, and the 16th measurement settles it (the misread landing
    # above measured 10-13 times in its whole start).
    reference = HeightReference()
    first_mm = [-13.8, -9.8, -4.9, -0.4, 4.4, 9.8, 11.7, 21.3]
    next_mm = [3.0, -8.0, 12.0, 0.0, 9.0, -6.0, 14.0, 1.0]  # within 20 mm of the estimate
    for count, value_mm in enumerate(first_mm + next_mm, start=1):
        feed(reference, [-value_mm / 1000.0], [GROUND_AREA_M2])
        assert reference.known == (count >= 16)
        if count == 8:
            assert reference.start_error_m > reference.params.start_known_error_m
    # Median (1 + 3) / 2 mm; quartiles -5.175 and 10.275 mm: standard error
    # 1.2533 · 15.45 / 1.349 / √16 = 3.59 mm, above `start_known_error_m`: the count settled it.
    assert reference.shift_m == pytest.approx(0.002)
    assert reference.start_error_m == pytest.approx(1.2533 * 0.01545 / 1.349 / 4.0)


def test_known_error_of_exact_measurements_is_zero():
    reference = HeightReference()
    assert reference.error_m == np.inf
    for _ in range(reference.params.min_frames):
        feed(reference, [-0.004], [GROUND_AREA_M2])
    assert reference.error_m == 0.0 and reference.known


def test_a_7_degree_neck_error_takes_the_ground_not_a_patch_of_the_first_step():
    # The paper's 7° neck bound puts the camera 24 mm too low (stage, seed 2): the ground
    # appears at -24 mm (beyond the 20 mm gate), a 0.31 m² patch of the 31 mm step at +7 mm.
    reference = HeightReference()
    for _ in range(reference.params.min_frames):
        assert feed(reference, [-0.024, 0.007], [4.0, 0.31]) == pytest.approx(0.024)
    assert reference.converged and reference.shift_m == pytest.approx(0.024)
    # Converged: the gate centres on the estimate, the step is not the ground.
    assert feed(reference, [0.007, -0.025], [0.31, 4.0], rise_m=0.2) == pytest.approx(0.025)


def test_walking_down_a_neck_error_beyond_the_gate_is_measured_around_the_neck_prior():
    # stage_down with a 7° neck bias (seed 2): the camera 21 mm too low, the ground at -21 mm
    # on the way down, beyond the 20 mm gate around the kinematics' 0; the tilt correction's
    # neck prior predicts a shift of +18 mm (`neck_prior_m`).
    kinematics = HeightReference()
    neck = HeightReference()
    for _ in range(kinematics.params.min_frames):
        assert feed(kinematics, [-0.021], [4.0], rise_m=-0.122) is None
        assert feed(neck, [-0.021], [4.0], rise_m=-0.122, prior_m=0.018) == pytest.approx(0.021)
    assert neck.converged and neck.shift_m == pytest.approx(0.021)
    assert not kinematics.converged
    # The ground 31 mm below a tread (at -21 - 31 mm) is outside the gate around the prior.
    assert feed(HeightReference(), [-0.052], [4.0], rise_m=-0.031, prior_m=0.018) is None


def test_the_wide_start_gate_ends_at_the_first_step_down():
    # Walking down: on the first tread (31 mm above the ground, odometry 31 mm below the start)
    # the ground appears 31 mm below the feet, +7 mm with a camera error of +7 mm: not the
    # ground under the feet. At the start level it would have been taken (-24 mm, 4 m²).
    reference = HeightReference()
    assert feed(reference, [-0.024], [4.0], rise_m=-0.031) is None
    assert feed(reference, [-0.024], [4.0], rise_m=-0.009) == pytest.approx(0.024)
    # Beyond the start gate or smaller than the ground around the robot: never.
    assert feed(reference, [-0.041], [4.0]) is None
    assert feed(reference, [-0.024], [0.9]) is None


def test_after_max_wait_frames_the_kinematics_are_trusted():
    reference = HeightReference(HeightReferenceParams(max_wait_frames=5))
    for i in range(5):
        assert not reference.known, i
        feed(reference, [-0.126], [5.6])
    assert reference.known and not reference.converged and reference.shift_m == 0.0


def test_after_convergence_the_gate_centres_on_the_estimate():
    params = HeightReferenceParams(gate_m=0.01, min_frames=2)
    reference = HeightReference(params)
    for _ in range(2):
        feed(reference, [-0.008], [GROUND_AREA_M2])
    # 17 mm from the estimate: not the ground; 2 mm from it (but 10 mm from 0): the ground.
    assert feed(reference, [0.009], [GROUND_AREA_M2]) is None
    assert feed(reference, [-0.010], [GROUND_AREA_M2]) == pytest.approx(0.010)


def test_non_floor_regions_are_never_measured():
    reference = HeightReference()
    assert feed(reference, [0.0], [GROUND_AREA_M2], floors=[False]) is None


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("gate_m", 0.0),
        ("gate_m", float("nan")),
        ("min_area_m2", -1.0),
        ("min_frames", 0),
        ("max_wait_frames", -1),
        ("frame_gate_m", 0.0),
        ("start_gate_m", -0.01),
        ("start_min_area_m2", float("inf")),
        ("start_level_m", 0.0),
        ("surface_gate_m", float("nan")),
        ("known_error_m", 0.0),
        ("known_error_m", float("inf")),
        ("start_known_error_m", 0.0),
        ("start_known_error_m", float("nan")),
        ("start_known_frames", 0),
        ("start_known_frames", 16.0),
        ("tread_min_area_m2", -0.01),
        ("tread_min_area_m2", 1.0),  # not below start_min_area_m2
        ("tread_min_area_m2", float("nan")),
        ("neck_in_camera_y_m", 1.5),
        ("neck_in_camera_z_m", float("nan")),
    ],
)
def test_bad_parameters_are_refused_naming_the_field(field, value):
    with pytest.raises(InvalidParameterError, match=f"HeightReferenceParams.{field}"):
        HeightReferenceParams(**{field: value})


def test_a_frame_agreeing_with_the_estimate_takes_its_own_measurement():
    # Bias 6 mm; the encoders' noise moves one frame's camera height by ±1.5 mm.
    reference = HeightReference()
    for h in (-0.006,) * reference.params.min_frames:
        feed(reference, [h], [GROUND_AREA_M2])
    gate = reference.params.frame_gate_m
    assert reference.frame_shift_m(0.0075) == 0.0075  # its own ground lies exactly on 0
    assert reference.frame_shift_m(0.0045) == 0.0045
    assert reference.frame_shift_m(0.006 + gate + 1e-4) == pytest.approx(0.006)  # a fragment
    assert reference.frame_shift_m(None) == pytest.approx(0.006)  # no ground in view


def test_arrival_drift_from_the_surface_the_first_frames_saw():
    # Walking down from a 122 mm platform, odometry drifts to -4 mm on arrival on the ground
    # (true height 0), in proportion to the way: frame k of 12 saw the ground 4·k/12 mm low.
    # Each frame also sees the platform's edge (0.122); frame 2 sees no ground.
    params = HeightReferenceParams()
    fractions = np.arange(12) / 12.0
    surfaces = [np.array([-0.004 * f, 0.122]) for f in fractions]
    surfaces[2] = np.array([0.122])
    drift = arrival_drift_m(surfaces, fractions, -0.004, 0.122, params)
    assert drift == pytest.approx(-0.004, abs=1e-12)
    # Fewer than min_frames frames saw it (or none within the gate): unknown.
    assert arrival_drift_m(surfaces[:8], fractions[:8], -0.004, 0.122, params) is None
    assert arrival_drift_m(surfaces, fractions, -0.004 - 0.021, 0.122, params) is None


def test_the_waiting_frames_camera_error_is_not_taken_for_drift():
    # As above, but the waiting frames (on the platform, the surface under their feet out of
    # view) had their camera 1.5 mm low, which none of them could measure: they saw the ground
    # at -1.5 - 4·f mm (stage_down seed 3). The drift is the slope over the way, -4 mm; taking
    # the camera error as 0 (each frame's (arrival - height) / (1 - f), the earliest frames'
    # median of the first 8) gives -2.3 mm. Frame 5 saw a wrong surface (9 mm): the median of
    # the slopes ignores it.
    params = HeightReferenceParams()
    fractions = np.arange(20) / 20.0
    surfaces = [np.array([-0.0015 - 0.004 * f, 0.122]) for f in fractions]
    surfaces[5] = np.array([0.009])
    drift = arrival_drift_m(surfaces, fractions, -0.004, 0.122, params)
    assert drift == pytest.approx(-0.004, abs=1e-12)


def test_arriving_at_the_start_level_the_drift_is_odometry_s_change_exactly():
    # The reference converged while the robot still stands at its start level: the ground under
    # its feet is the start surface, at the start pose's z by the kinematics. The waiting
    # frames' views of it scatter by +-20 mm (stereo), which must not become a drift.
    params = HeightReferenceParams()
    fractions = np.arange(8) / 8.0
    views_m = np.array([0.0147, 0.0237, 0.0201, -0.0067, 0.0209, -0.0056, -0.0108, -0.0015])
    surfaces = [np.array([v]) for v in views_m]
    assert arrival_drift_m(surfaces, fractions, 0.0, 0.0, params) == 0.0
    assert arrival_drift_m(surfaces, fractions, 0.1215, 0.122, params) == pytest.approx(-0.0005)
    # Off the start level (a step down), the views are used.
    assert arrival_drift_m(surfaces, fractions, -0.031, 0.0, params) is None  # none in gate


def test_the_start_surface_under_the_feet_is_the_median_of_the_first_frames():
    params = HeightReferenceParams()
    surfaces = [np.array([0.001, 0.122]), np.array([0.121]), np.array([-0.002, 0.12])]
    surfaces += [np.array([0.0005])]
    # Largest (listed first) within 10 mm of 3 mm, per frame that has one: 1, -2, 0.5 mm;
    # their median (the robot started on the platform: 122 mm).
    assert start_surface_m(surfaces, 0.003, 0.122, params) == pytest.approx(0.0005)
    assert start_surface_m(surfaces, 0.118, 0.5, params) == pytest.approx(0.121)
    assert start_surface_m(surfaces, 0.05, 0.122, params) is None


def test_a_start_surface_is_the_median_of_every_waiting_frame_s_view_of_it():
    # Walking down from the platform (start z 122 mm), 20 frames waited and saw the ground
    # (drift taken out): the first 8 at -1.5 mm (their noise), the other 12 at 0. The median
    # of all: 0; of the earliest 8 (before): -1.5 mm (stage_down seed 3, the ground row).
    params = HeightReferenceParams()
    surfaces = [np.array([-0.0015, 0.122])] * 8 + [np.array([0.0, 0.122])] * 12
    assert start_surface_m(surfaces, 0.002, 0.122, params) == 0.0


def test_the_surface_the_feet_stood_on_at_the_start_is_at_the_start_pose_s_z():
    # Stereo: the first frames' views of the ground under the feet scatter by +-20 mm, in two
    # clusters (seed 6). With the robot's elevation pulled 8 mm low, the views nearest it (-8
    # to -17 mm) gave -13.5 mm, and the robot stood there for the rest of the run. The feet
    # stood on that surface at the start: it is at the start pose's z, exactly.
    params = HeightReferenceParams()
    views_m = [-0.0081, -0.0171, -0.0135, 0.0133, -0.0143, 0.0122, 0.0174, 0.0081]
    surfaces = [np.array([v]) for v in views_m]
    assert start_surface_m(surfaces, -0.0081, 0.0, params) == 0.0
    assert start_surface_m(surfaces, 0.128, 0.122, params) == 0.122
    # Beyond the surface gate the views decide (another surface): -17.1, -14.3, -13.5, -8.1.
    assert start_surface_m(surfaces, -0.0135, 0.0, params) == pytest.approx(-0.0139)


def test_the_largest_fragment_of_a_start_surface_is_taken_wherever_the_robot_is():
    # Depth noise split the ground of every first frame into a 4 m² plane at 0 and a 0.5 m²
    # fragment 0.8 mm lower (room, seed 3): the elevation near either gives the ground.
    # (The robot started on a 122 mm platform: the ground is not the start surface.)
    params = HeightReferenceParams()
    reference = HeightReference(params)
    heights = np.array([-0.0008, 0.0, -0.122])  # the fragment, the ground, a pit
    ordered = reference.ground_sized_m(heights, np.array([0.5, 4.0, 1.0]), np.ones(3, bool))
    np.testing.assert_array_equal(ordered, [0.0, -0.122, -0.0008])
    surfaces = [ordered] * 8  # world heights with odometry's z 0 and no shift
    assert start_surface_m(surfaces, -0.0008, 0.122, params) == 0.0
    assert start_surface_m(surfaces, 0.0, 0.122, params) == 0.0
