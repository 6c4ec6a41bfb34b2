import math

import mujoco
import numpy as np
import pytest

from fogsim.errors import CameraError, ParameterError
from fogsim.robot import EncoderModel, SelfFilter, SelfFilterParams, Stance, load_robot, plan_route
from mapper.intrinsics import PinholeIntrinsics

WIDTH, HEIGHT = 88, 72
FOCAL = 0.5 * HEIGHT / math.tan(math.radians(39.0) / 2)  # MuJoCo: fovy 39°, square pixels
INTRINSICS = PinholeIntrinsics(WIDTH, HEIGHT, FOCAL, FOCAL, (WIDTH - 1) / 2, (HEIGHT - 1) / 2)
CLEARANCE_M = SelfFilterParams().ground_clearance_m


@pytest.fixture(scope="module")
def icub():
    return load_robot("icub")


@pytest.fixture(scope="module")
def standing(icub):
    flat = lambda xy: np.zeros(len(xy))  # noqa: E731
    return plan_route(icub, (0.0, 0.0, 0.0), [{"look": (0.0, -40.0)}], flat, 12.5).q[-1]


def render(icub, q):
    """MuJoCo's own depth and segmentation of the standalone robot standing on a plane."""
    spec = mujoco.MjSpec.from_file(str(icub.mjcf_path))
    spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[5, 5, 0.1])
    model = spec.compile()
    data = mujoco.MjData(model)
    data.qpos[:] = icub.qpos_mujoco(q)
    mujoco.mj_fwdPosition(model, data)
    renderer = mujoco.Renderer(model, HEIGHT, WIDTH)
    try:
        renderer.enable_depth_rendering()
        renderer.update_scene(data, "head_camera")
        depth = renderer.render().copy()
        renderer.disable_depth_rendering()
        renderer.enable_segmentation_rendering()
        renderer.update_scene(data, "head_camera")
        segmentation = renderer.render()[..., 0].copy()
    finally:
        renderer.close()
    floor = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "floor")
    # pixels on the robot; those within the ground clearance of the floor are floor to any
    # mapper (the soles' edges touch the floor), so they are not required to be removed
    points = INTRINSICS.depth_to_points_camera(depth)
    camera = icub.transform_camera_to_world(q)
    z_world = points @ camera[2, :3] + camera[2, 3]
    robot = (segmentation >= 0) & (segmentation != floor)
    return depth, robot, robot & (z_world > CLEARANCE_M), segmentation == floor


@pytest.fixture(scope="module")
def looking_at_feet(icub, standing):
    q = standing.copy()
    q[7 + icub.joint_index("torso_pitch")] = 1.1  # bow so the feet come into view
    return q, *render(icub, q)


def test_exact_readings_remove_every_robot_point_and_no_floor(icub, looking_at_feet):
    q, depth, _robot, robot_above_floor, floor = looking_at_feet
    assert robot_above_floor.sum() > 300  # the feet and legs are in view
    self_filter = SelfFilter(icub)
    mask = self_filter.mask(
        depth, INTRINSICS, q[7:], icub.transform_camera_to_robot(q, Stance.LEFT)
    )
    assert not np.any(robot_above_floor & ~mask)
    assert not np.any(floor & mask)
    filtered, removed = self_filter.apply(
        depth, INTRINSICS, q[7:], icub.transform_camera_to_robot(q, Stance.LEFT)
    )
    assert removed == int(mask.sum())
    assert np.all(np.isnan(filtered[mask])) and not np.any(np.isnan(filtered[~mask]))


def test_default_encoder_errors_still_remove_the_robot(icub, looking_at_feet):
    q, depth, robot, _, floor = looking_at_feet
    # With encoder errors the believed ground plane tilts by 1-2°, so robot points within 1 cm of
    # the floor (sole edges) cannot be told from floor; everything higher must go.
    camera = icub.transform_camera_to_world(q)
    z_world = INTRINSICS.depth_to_points_camera(depth) @ camera[2, :3] + camera[2, 3]
    robot_above_floor = robot & (z_world > 0.01)
    self_filter = SelfFilter(icub)
    floor_lost = []
    for seed in range(10):
        readings = EncoderModel(0.5, 0.2, np.random.default_rng(seed)).read(q)
        mask = self_filter.mask(
            depth, INTRINSICS, readings, icub.transform_camera_to_robot(readings, Stance.LEFT)
        )
        assert not np.any(robot_above_floor & ~mask), f"seed {seed}"
        floor_lost.append((floor & mask).sum() / floor.sum())
    assert max(floor_lost) < 0.1  # the margin costs little floor


def test_walking_view_has_no_false_positives(icub, standing):
    q = standing.copy()
    q[7 + icub.joint_index("neck_pitch")] = -math.radians(30.0)
    depth, robot, _, floor = render(icub, q)
    assert not robot.any() and floor.all()
    mask = SelfFilter(icub).mask(
        depth, INTRINSICS, q, icub.transform_camera_to_robot(q, Stance.LEFT)
    )
    assert not mask.any()


def test_empty_and_invalid_depth(icub, standing):
    self_filter = SelfFilter(icub)
    nothing = np.full((HEIGHT, WIDTH), np.nan)
    assert not self_filter.mask(nothing, INTRINSICS, standing).any()
    with pytest.raises(CameraError, match="4×4"):
        self_filter.mask(nothing, INTRINSICS, standing, np.eye(3))
    with pytest.raises(ParameterError, match="margin_m"):
        SelfFilterParams(margin_m=-0.1)
