import math

import mujoco
import numpy as np
import pinocchio as pin
import pytest

from fogsim.errors import RobotModelError
from fogsim.robot import (
    CAMERA_NAMES,
    ROBOT_NAMES,
    Stance,
    load_description,
    load_robot,
    read_description,
)
from fogsim.robot.description import ROBOTS_DIR
from fogsim.robot.mjcf import mjcf_files
from mapper.transforms import planar_pose_to_matrix


@pytest.fixture(scope="module")
def icub():
    return load_robot("icub")


@pytest.fixture(scope="module")
def icub_mj(icub):
    model = mujoco.MjModel.from_xml_path(str(icub.mjcf_path))
    return model, mujoco.MjData(model)


def _upright(robot, yaw_rad=0.0, xyz=(0.0, 0.0, 0.6)):
    """Neutral joints, root rotated so the robot faces yaw_rad (iCub's root x points back)."""
    q = robot.neutral()
    q[:3] = xyz
    rotation = pin.utils.rpyToMatrix(0.0, 0.0, yaw_rad + math.pi)
    q[3:7] = pin.Quaternion(rotation).coeffs()
    return q


def test_bad_name_lists_valid_names():
    with pytest.raises(RobotModelError, match="icub, talos"):
        load_robot("qrio")


def test_model_shapes_and_names(icub, icub_mj):
    model, _ = icub_mj
    assert icub.nq == 39 and icub.n_joints == 32
    assert icub.mujoco_joint_names[0] == "root"
    assert sorted(icub.mujoco_joint_names[1:]) == sorted(icub.joint_names)
    for name in CAMERA_NAMES:
        cid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, name)
        assert cid >= 0 and model.cam_fovy[cid] == pytest.approx(39.0)
    for kind, count in (
        (mujoco.mjtObj.mjOBJ_BODY, model.nbody),
        (mujoco.mjtObj.mjOBJ_GEOM, model.ngeom),
    ):
        names = [mujoco.mj_id2name(model, kind, i) for i in range(1, count)]
        assert all(names) and len(set(names)) == len(names)
    assert load_robot("icub") is icub  # cached


def test_mujoco_agrees_with_pinocchio_for_random_configurations(icub, icub_mj):
    model, data = icub_mj
    np.random.seed(3)  # pinocchio's randomConfiguration draws from numpy's global generator
    checked = 0
    for _ in range(5):
        q = pin.randomConfiguration(icub.pin_model, -np.ones(icub.nq), np.ones(icub.nq))
        data.qpos[:] = icub.qpos_mujoco(q)
        mujoco.mj_fwdPosition(model, data)
        for frame in icub.pin_model.frames:
            sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, frame.name)
            if sid < 0:
                continue
            pose = icub.frame_transforms(q, (frame.name,))[0]
            np.testing.assert_allclose(data.site_xpos[sid], pose[:3, 3], atol=1e-9)
            np.testing.assert_allclose(data.site_xmat[sid].reshape(3, 3), pose[:3, :3], atol=1e-9)
            checked += 1
        for name in CAMERA_NAMES:
            cid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, name)
            pose = icub.transform_camera_to_world(q, name)
            np.testing.assert_allclose(data.cam_xpos[cid], pose[:3, 3], atol=1e-9)
            r_cv = data.cam_xmat[cid].reshape(3, 3) @ np.diag([1.0, -1.0, -1.0])
            np.testing.assert_allclose(r_cv, pose[:3, :3], atol=1e-9)
        # every body of a joint sits where pinocchio puts the joint
        for joint_id in range(1, icub.pin_model.njoints):
            jid = mujoco.mj_name2id(
                model,
                mujoco.mjtObj.mjOBJ_JOINT,
                "root" if joint_id == 1 else icub.pin_model.names[joint_id],
            )
            body = model.jnt_bodyid[jid]
            np.testing.assert_allclose(
                data.xpos[body], icub.pin_data.oMi[joint_id].translation, atol=1e-9
            )
    assert checked >= 5 * 20


def test_head_camera_looks_forward_and_stereo_baseline(icub):
    yaw = math.radians(30.0)
    q = _upright(icub, yaw)
    camera = icub.transform_camera_to_world(q)
    forward = np.array([math.cos(yaw), math.sin(yaw), 0.0])
    np.testing.assert_allclose(camera[:3, 2], forward, atol=1e-4)  # optical z
    np.testing.assert_allclose(camera[:3, 1], [0.0, 0.0, -1.0], atol=1e-4)  # image y down
    # eyes ~0.94 m above the soles (iCub is ~1.04 m tall)
    sole = icub.frame_transforms(q, ("l_sole",))[0]
    assert 0.9 < camera[2, 3] - sole[2, 3] < 1.0
    left = icub.transform_camera_to_world(q, "head_camera_left")
    right = icub.transform_camera_to_world(q, "head_camera_right")
    assert np.linalg.norm(left[:3, 3] - right[:3, 3]) == pytest.approx(0.068, abs=1e-12)
    # left camera is to the robot's left (+y of a robot facing +x rotated by yaw)
    leftward = np.array([-math.sin(yaw), math.cos(yaw), 0.0])
    assert (left[:3, 3] - right[:3, 3]) @ leftward == pytest.approx(0.068, abs=1e-6)


def test_neck_pitch_negative_looks_down(icub):
    q = _upright(icub)
    q[7 + icub.joint_index("neck_pitch")] = -math.radians(30.0)
    camera = icub.transform_camera_to_world(q)
    pitch_down = math.degrees(math.asin(-camera[2, 2]))
    assert pitch_down == pytest.approx(30.0, abs=0.01)  # URDF axes are off by ~1e-5 rad


def test_qpos_mapping_quaternion_order(icub):
    q = _upright(icub, 0.3, (1.0, 2.0, 0.5))
    qpos = icub.qpos_mujoco(q)
    np.testing.assert_array_equal(qpos[:3], q[:3])
    np.testing.assert_array_equal(qpos[3:7], [q[6], q[3], q[4], q[5]])


@pytest.mark.parametrize("stance", [Stance.LEFT, Stance.RIGHT, Stance.DOUBLE])
def test_robot_frame_and_camera_compose_to_the_true_camera(icub, stance):
    yaw = math.radians(-50.0)
    q = _upright(icub, yaw, (0.4, -0.2, 0.75))
    pose = icub.robot_frame_in_world(q, stance)
    soles = icub.frame_transforms(q, ("l_sole", "r_sole"))
    reference = soles[1] if stance == Stance.RIGHT else soles[0]
    assert pose[2] == pytest.approx(reference[2, 3], abs=1e-12)
    # the URDF's soles are tilted ~1e-5 rad at zero joints, hence the loose tolerances
    assert pose[3] == pytest.approx(yaw, abs=1e-5)
    # R is midway between the feet, 5 cm ahead of the heel-side sole origins
    mid = 0.5 * (soles[0][:3, 3] + soles[1][:3, 3]) + 0.05 * np.array(
        [math.cos(yaw), math.sin(yaw), 0]
    )
    np.testing.assert_allclose(pose[:2], mid[:2], atol=1e-6)
    composed = planar_pose_to_matrix(pose) @ icub.transform_camera_to_robot(q[7:], stance)
    np.testing.assert_allclose(composed, icub.transform_camera_to_world(q), atol=5e-5)


def test_wrong_configuration_size_is_rejected(icub):
    with pytest.raises(RobotModelError, match="39"):
        icub.transform_camera_to_robot(np.zeros(5))


@pytest.mark.parametrize("name", ROBOT_NAMES)
def test_every_robot_loads_with_cameras(name):
    robot = load_robot(name)
    q = robot.neutral()
    camera = robot.transform_camera_to_world(q)
    sole = robot.frame_transforms(q, (robot.description.feet.left_sole,))[0]
    assert camera[2, 3] > sole[2, 3] + 0.5
    model = mujoco.MjModel.from_xml_path(str(robot.mjcf_path))
    assert model.nq == robot.nq


@pytest.mark.parametrize("name", ROBOT_NAMES)
def test_the_neck_pivot_is_where_the_neck_joints_turn_the_camera(name):
    # The description's pivot (the tilt correction turns the data about it) is the origin of
    # the camera's parent joint, in the camera's optical frame, and every neck joint turns
    # the head about a point within 1 cm of it.
    robot = load_robot(name)
    model, data = robot.pin_model, robot.pin_model.createData()
    camera = model.frames[robot.frame_id("head_camera")]
    assert model.names[camera.parentJoint] == robot.description.camera.parent_joint
    pivot = np.array(robot.description.neck.pivot_in_camera_m)
    np.testing.assert_allclose(pivot, camera.placement.inverse().translation, atol=0.001)
    pin.forwardKinematics(model, data, robot.neutral())
    pin.updateFramePlacements(model, data)
    for joint in robot.description.neck.joints:
        origin = data.oMf[robot.frame_id("head_camera")].actInv(
            data.oMi[model.getJointId(joint)].translation
        )
        assert np.linalg.norm(origin - pivot) < 0.01, joint
    assert pivot[1] > 0.05 and pivot[2] < -0.05  # below and behind the eyes


def test_model_is_built_into_the_cache_dir_given_by_fogsim_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("FOGSIM_CACHE", str(tmp_path))
    robot = load_robot.__wrapped__("icub")  # bypass the per-process cache
    assert robot.mjcf_path.parent == tmp_path / "robots" / "icub"
    model = mujoco.MjModel.from_xml_path(str(robot.mjcf_path))  # its meshes from the files
    assert model.nmesh > 0 and model.njnt == 33
    # One .msh per mesh, in the folder named as the MJCF beside it.
    meshes = mjcf_files(robot.mjcf_path)[1:]
    assert len(meshes) == model.nmesh
    assert {path.parent for path in meshes} == {robot.mjcf_path.with_suffix("")}
    assert sorted(p.name for p in robot.mjcf_path.with_suffix("").iterdir()) == sorted(
        path.name for path in meshes
    )


def test_shipped_descriptions_hold_the_values_of_the_former_literals():
    assert ROBOT_NAMES == ("icub", "talos")
    icub = load_description("icub")
    assert icub.name == "icub" and icub.example_robot_data == "icub"
    assert (icub.feet.left_sole, icub.feet.right_sole) == ("l_sole", "r_sole")
    assert icub.feet.center_offset_m == 0.05
    assert icub.feet.length_m == (-0.028, 0.128) and icub.feet.half_width_m == 0.03
    assert icub.legs.left_joints == (
        "l_hip_pitch", "l_hip_roll", "l_hip_yaw", "l_knee", "l_ankle_pitch", "l_ankle_roll",
    )  # fmt: skip
    assert icub.legs.right_joints[3] == "r_knee" and icub.legs.pelvis_height_m == 0.575
    assert icub.neck.joints == ("neck_pitch", "neck_roll", "neck_yaw")
    assert (icub.neck.yaw_joint, icub.neck.pitch_joint, icub.neck.pitch_sign) == (
        "neck_yaw", "neck_pitch", 1.0,
    )  # fmt: skip
    assert icub.camera.parent_joint == "neck_yaw" and icub.camera.frame is None
    assert icub.camera.position_in_parent_m == (-0.09, -0.10, 0.0)
    assert icub.camera.forward_in_parent == (-1.0, 0.0, 0.0)
    assert icub.camera.up_in_parent == (0.0, -1.0, 0.0)
    assert icub.camera.stereo_baseline_m == 0.068 and icub.camera.ahead_m == 0.0
    assert icub.quirks.fix_y_up_meshes and not icub.quirks.collision_meshes_for_visuals
    assert dict(icub.arm_pose_rad) == {
        "l_shoulder_roll": 0.35, "r_shoulder_roll": 0.35, "l_elbow": 0.6, "r_elbow": 0.6,
        "l_shoulder_pitch": -0.2, "r_shoulder_pitch": -0.2,
    }  # fmt: skip

    talos = load_description("talos")
    assert (talos.feet.left_sole, talos.feet.right_sole) == ("left_sole_link", "right_sole_link")
    assert talos.feet.center_offset_m == 0.0
    assert talos.feet.length_m == (-0.1, 0.1) and talos.feet.half_width_m == 0.065
    assert talos.legs.left_joints == tuple(f"leg_left_{i}_joint" for i in range(1, 7))
    assert talos.legs.right_joints == tuple(f"leg_right_{i}_joint" for i in range(1, 7))
    assert talos.legs.pelvis_height_m == 0.98
    assert talos.neck.joints == ("head_1_joint", "head_2_joint")
    assert (talos.neck.yaw_joint, talos.neck.pitch_joint, talos.neck.pitch_sign) == (
        "head_2_joint", "head_1_joint", -1.0,
    )  # fmt: skip
    assert (talos.camera.parent_joint, talos.camera.frame) == ("head_2_joint", "rgbd_optical_frame")
    assert talos.camera.position_in_parent_m is None
    assert talos.camera.stereo_baseline_m == 0.07 and talos.camera.ahead_m == 0.05
    assert talos.quirks.collision_meshes_for_visuals and not talos.quirks.fix_y_up_meshes
    assert dict(talos.arm_pose_rad) == {
        "arm_left_2_joint": 0.25, "arm_right_2_joint": -0.25,
        "arm_left_4_joint": -0.5, "arm_right_4_joint": -0.5,
    }  # fmt: skip


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        ("half_width_m = 0.03", 'half_width_m = "wide"', "feet.half_width_m: Expected `float`"),
        ("stereo_baseline_m = 0.068", "stereo_baseline_m = -0.068", "camera.stereo_baseline_m"),
        ("pelvis_height_m = 0.575", "", "legs.pelvis_height_m: missing"),
        ('"l_ankle_pitch", "l_ankle_roll"]', '"l_ankle_pitch"]', "legs.left_joints: Expected"),
        (
            "fix_y_up_meshes = true",
            "fix_y_up_meshes = true\ncolour = 1",
            "unknown key quirks.colour",
        ),
        ("l_elbow = 0.6", "l_elbow = 6.0", "arm_pose_rad.l_elbow = 6.0"),
        ("pitch_sign = 1.0", "pitch_sign = 0.5", "neck.pitch_sign = 0.5"),
        ('yaw_joint = "neck_yaw"', 'yaw_joint = "neck_twist"', "neck.yaw_joint = 'neck_twist'"),
        ("length_m = [-0.028, 0.128]", "length_m = [0.128, -0.028]", "feet.length_m"),
        ('parent_joint = "neck_yaw"', 'parent_joint = "neck_yaw"\nframe = "eye"', "camera.frame"),
        ("up_in_parent = [0.0, -1.0, 0.0]", "", "camera.up_in_parent is missing"),
        ("up_in_parent = [0.0, -1.0, 0.0]", "up_in_parent = [-1.0, 0.0, 0.0]", "not parallel"),
        (
            'example_robot_data = "icub"',
            'name = "icub"',
            "unknown key name; allowed there: example",
        ),
        ('example_robot_data = "icub"', "", "example_robot_data: missing"),
        ("[feet]", "[feet", "not valid TOML"),
    ],
)
def test_malformed_description_names_the_file_and_key(tmp_path, old, new, message):
    text = (ROBOTS_DIR / "icub.toml").read_text()
    assert old in text
    path = tmp_path / "icub.toml"
    path.write_text(text.replace(old, new, 1))
    with pytest.raises(RobotModelError) as raised:
        read_description(path)
    assert str(raised.value).startswith(f"{path}: ")
    assert message in str(raised.value)


def test_missing_description_file_is_a_robot_model_error(tmp_path):
    with pytest.raises(RobotModelError, match="cannot read"):
        read_description(tmp_path / "asimo.toml")
