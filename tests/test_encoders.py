import math

import numpy as np
import pytest

from fogsim.config import EncoderConfig, load_scenario
from fogsim.errors import EncoderError
from fogsim.geometry import pose_error
from fogsim.robot import (
    EncoderModel,
    JointGroup,
    Odometry,
    Stance,
    joint_groups,
    load_robot,
    plan_route,
)
from tests.test_walking import stage_support


@pytest.fixture(scope="module")
def icub():
    return load_robot("icub")


@pytest.fixture(scope="module")
def walk(icub):
    route = [{"walk_to": (2.0, 0.5)}, {"walk_to": (3.6, 0.5)}, {"turn_to": 90.0}]
    return plan_route(icub, (0.3, 0.5, 0.0), route, stage_support, 12.5)


def test_no_errors_means_readings_and_believed_pose_are_exact(icub, walk):
    encoders = EncoderModel(0.0, 0.0, np.random.default_rng(0))
    for i in range(0, walk.frame_count, 25):
        readings = encoders.read(walk.q[i])
        np.testing.assert_array_equal(readings, walk.q[i, 7:])
        ref = walk.reference_foot[i]
        np.testing.assert_array_equal(
            icub.transform_camera_to_robot(readings, ref),
            icub.transform_camera_to_robot(walk.q[i], ref),
        )


def test_reading_statistics_match_the_injected_errors():
    n_joints, n_reads = 32, 4000
    encoders = EncoderModel(0.5, 0.2, np.random.default_rng(7), n_joints=n_joints)
    truth = np.linspace(-1.0, 1.0, n_joints)
    errors = np.degrees(np.stack([encoders.read(truth, 0) - truth for _ in range(n_reads)]))
    bias_deg = np.degrees(encoders.bias_rad)
    # per joint: mean = the run's bias, spread = the noise
    np.testing.assert_allclose(errors.mean(axis=0), bias_deg, atol=4 * 0.2 / math.sqrt(n_reads))
    np.testing.assert_allclose(errors.std(axis=0), 0.2, rtol=0.1)
    # biases over many runs: zero mean, std = bias_deg
    biases = np.concatenate(
        [
            np.degrees(EncoderModel(0.5, 0.2, np.random.default_rng(s), n_joints).bias_rad)
            for s in range(300)
        ]
    )
    assert biases.std() == pytest.approx(0.5, rel=0.05)
    assert abs(biases.mean()) < 4 * 0.5 / math.sqrt(biases.size)


def test_same_seed_same_readings_bit_for_bit(walk):
    a = EncoderModel(0.5, 0.2, np.random.default_rng(11))
    b = EncoderModel(0.5, 0.2, np.random.default_rng(11))
    for q in walk.q[:20]:
        np.testing.assert_array_equal(a.read(q), b.read(q))


def test_neck_bias_gives_known_camera_error(icub, walk):
    """A 2° error on neck pitch alone: 2° camera rotation, 2°·lever translation."""
    q = walk.q[0]
    readings = q[7:].copy()
    readings[icub.joint_index("neck_pitch")] += math.radians(2.0)
    error = pose_error(
        icub.transform_camera_to_robot(readings, Stance.LEFT),
        icub.transform_camera_to_robot(q, Stance.LEFT),
    )
    assert error.rotation_deg == pytest.approx(2.0, abs=1e-6)
    # lever: distance from the neck-pitch axis to the camera, perpendicular to the axis
    model, data = icub.pin_model, icub.pin_data
    joint = model.getJointId("neck_pitch")
    icub.frame_transforms(q, ("head_camera",))
    local_axis = {"JointModelRX": 0, "JointModelRY": 1, "JointModelRZ": 2}[
        model.joints[joint].shortname()
    ]
    axis_world = data.oMi[joint].rotation[:, local_axis]
    offset = icub.transform_camera_to_world(q)[:3, 3] - data.oMi[joint].translation
    lever = np.linalg.norm(offset - axis_world * (offset @ axis_world))
    assert error.translation_mm == pytest.approx(
        1000 * 2 * lever * math.sin(math.radians(1.0)), rel=1e-6
    )


def test_default_errors_give_degrees_and_centimetres(icub, walk):
    rotations, translations = [], []
    for seed in range(3):
        encoders = EncoderModel(0.5, 0.2, np.random.default_rng(seed))
        for i in range(0, walk.frame_count, 10):
            ref = walk.reference_foot[i]
            e = pose_error(
                icub.transform_camera_to_robot(encoders.read(walk.q[i]), ref),
                icub.transform_camera_to_robot(walk.q[i], ref),
            )
            rotations.append(e.rotation_deg)
            translations.append(e.translation_mm)
    assert 0.5 < np.median(rotations) < 3.0 and np.max(rotations) < 7.0
    assert 3.0 < np.median(translations) < 30.0


def test_odometry_is_exact_without_errors_and_drifts_with_them(icub, walk):
    exact = EncoderModel(0.0, 0.0, np.random.default_rng(0))
    noisy = EncoderModel(0.5, 0.2, np.random.default_rng(0))
    odo_exact = Odometry(icub, walk.robot_pose_true[0], exact.read(walk.q[0]), walk.stance[0])
    odo_noisy = Odometry(icub, walk.robot_pose_true[0], noisy.read(walk.q[0]), walk.stance[0])
    worst = 0.0
    for i in range(walk.frame_count):
        pose = odo_exact.update(exact.read(walk.q[i]), walk.stance[i])
        worst = max(worst, float(np.abs(pose - walk.robot_pose_true[i]).max()))
        drifted = odo_noisy.update(noisy.read(walk.q[i]), walk.stance[i])
    assert worst < 2e-4  # the IK residual and the URDF's 1e-5 rad sole tilt
    end_error = np.hypot(*(drifted[:2] - walk.robot_pose_true[-1, :2]))
    assert 0.005 < end_error < 0.5


def test_bad_parameters_are_rejected():
    with pytest.raises(EncoderError, match="bias_deg"):
        EncoderModel(-1.0, 0.2, np.random.default_rng(0))
    with pytest.raises(EncoderError, match="rng"):
        EncoderModel(0.5, 0.2, 3)
    encoders = EncoderModel(0.5, 0.2, np.random.default_rng(0), n_joints=32)
    with pytest.raises(EncoderError, match="32 joint angles"):
        encoders.read(np.zeros(5))


def test_joint_groups_of_both_robots(icub):
    groups = joint_groups(icub)
    by_name = dict(zip(icub.joint_names, groups.tolist(), strict=True))
    assert by_name["l_knee"] == JointGroup.LEG and by_name["r_ankle_roll"] == JointGroup.LEG
    assert {n for n, g in by_name.items() if g == JointGroup.TORSO} == {
        "torso_pitch",
        "torso_roll",
        "torso_yaw",
    }
    assert {n for n, g in by_name.items() if g == JointGroup.NECK} == {
        "neck_pitch",
        "neck_roll",
        "neck_yaw",
    }
    assert by_name["l_elbow"] == JointGroup.OTHER
    talos = load_robot("talos")
    talos_groups = dict(zip(talos.joint_names, joint_groups(talos).tolist(), strict=True))
    assert {n for n, g in talos_groups.items() if g == JointGroup.NECK} == {
        "head_1_joint",
        "head_2_joint",
    }
    assert talos_groups["torso_2_joint"] == JointGroup.TORSO


def test_per_group_statistics_match_the_injected_errors(icub):
    """Body joints get bias/noise std (0.05°, 0.02°), neck joints (4°, 0.3°), seeded."""
    neck = joint_groups(icub) == JointGroup.NECK
    n_reads = 3000
    truth = np.zeros(icub.n_joints)
    encoders = EncoderModel.for_robot(
        icub, 0.05, 0.02, np.random.default_rng(5), head_bias_deg=4.0, head_noise_deg=0.3
    )
    np.testing.assert_array_equal(encoders.bias_std_deg, np.where(neck, 4.0, 0.05))
    np.testing.assert_array_equal(encoders.noise_std_deg, np.where(neck, 0.3, 0.02))
    errors = np.degrees(np.stack([encoders.read(truth) for _ in range(n_reads)]))
    noise_std = np.where(neck, 0.3, 0.02)
    np.testing.assert_allclose(errors.std(axis=0), noise_std, rtol=0.1)
    np.testing.assert_allclose(
        errors.mean(axis=0), np.degrees(encoders.bias_rad), atol=4 * 0.3 / math.sqrt(n_reads)
    )
    # bias spread per group over many seeded runs
    biases = np.stack(
        [
            np.degrees(
                EncoderModel.for_robot(
                    icub, 0.05, 0.02, np.random.default_rng(s), head_bias_deg=4.0
                ).bias_rad
            )
            for s in range(400)
        ]
    )
    assert biases[:, neck].std() == pytest.approx(4.0, rel=0.06)
    assert biases[:, ~neck].std() == pytest.approx(0.05, rel=0.03)


def test_equal_levels_reproduce_the_single_level_model_bit_for_bit(icub, walk):
    single = EncoderModel(0.5, 0.2, np.random.default_rng(3))
    grouped = EncoderModel.for_robot(
        icub, 0.5, 0.2, np.random.default_rng(3), head_bias_deg=0.5, head_noise_deg=0.2
    )
    for q in walk.q[:10]:
        np.testing.assert_array_equal(single.read(q), grouped.read(q))


def test_paper_defaults_give_degrees_at_the_neck_and_millimetres(icub, walk):
    """Scenario defaults: camera-in-robot error of several degrees and about 10 mm (seeded)."""
    config = EncoderConfig()
    rotations, translations = [], []
    for seed in range(3):
        encoders = EncoderModel.for_robot(
            icub,
            config.bias_deg,
            config.noise_deg,
            np.random.default_rng(seed),
            head_bias_deg=config.head_bias_deg,
            head_noise_deg=config.head_noise_deg,
        )
        for i in range(0, walk.frame_count, 10):
            ref = walk.reference_foot[i]
            e = pose_error(
                icub.transform_camera_to_robot(encoders.read(walk.q[i]), ref),
                icub.transform_camera_to_robot(walk.q[i], ref),
            )
            rotations.append(e.rotation_deg)
            translations.append(e.translation_mm)
    # rotation: the neck's 4° std over three joints (about 1.6 × 4° typical, 13° on seed 2)
    assert 3.0 < np.median(rotations) < 8.0 and 5.0 < np.max(rotations) < 15.0
    # translation: about 2 mm per degree of neck error plus a few mm from the legs
    assert 5.0 < np.median(translations) < 15.0 and np.max(translations) < 30.0


def test_bad_group_parameters_are_rejected():
    with pytest.raises(EncoderError, match="head_bias_deg"):
        EncoderModel(0.5, 0.2, np.random.default_rng(0), head_bias_deg=-1.0)
    with pytest.raises(EncoderError, match="head_joints"):
        EncoderModel(0.5, 0.2, np.random.default_rng(0), 5, head_joints=[7])


def test_scenario_head_levels_default_to_the_body_levels_a_file_gives():
    legacy = load_scenario("box_removal").encoders  # bias_deg/noise_deg only: one level
    assert (legacy.head_bias_deg, legacy.head_noise_deg) == (legacy.bias_deg, legacy.noise_deg)
    assert load_scenario("flat_floor").encoders == EncoderConfig()  # no [encoders] table
    stage = load_scenario("stage").encoders
    assert (stage.bias_deg, stage.noise_deg, stage.head_bias_deg, stage.head_noise_deg) == (
        0.05,
        0.02,
        4.0,
        0.3,
    )
    zero = load_scenario("stage").with_overrides(["encoders.head_bias_deg=0"]).encoders
    assert zero.head_bias_deg == 0.0 and zero.bias_deg == 0.05
