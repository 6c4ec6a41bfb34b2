import math

import mujoco
import numpy as np
import pytest

from fogsim.config import load_scenario
from fogsim.errors import RouteError
from fogsim.robot import GaitParams, Stance, load_robot, plan_route
from fogsim.robot.walking.body import BodyKinematics
from fogsim.robot.walking.limits import MAX_TRAJECTORY_FRAMES
from fogsim.robot.walking.route import FrameBudget
from fogsim.world import SceneTruth
from mapper.transforms import planar_pose_to_matrix

PLATFORM_M = 0.122


def stage_support(xy):
    """The paper's stage along x: sill 38 mm, three 0.2 m treads, platform 122 mm."""
    x = np.asarray(xy, dtype=float)[:, 0]
    h = np.zeros(x.size)
    h = np.where((x >= 1.15) & (x <= 1.25), 0.038, h)
    for k, z in enumerate((0.031, 0.061, 0.092)):
        h = np.where((x >= 2.6 + 0.2 * k) & (x < 2.8 + 0.2 * k), z, h)
    return np.where((x >= 3.2) & (x <= 4.0), PLATFORM_M, h)


def flat_support(xy):
    return np.zeros(np.asarray(xy).shape[0])


STAGE_ROUTE = [
    {"walk_to": (2.0, 0.5)},
    {"look": (20.0, -25.0)},
    {"walk_to": (3.6, 0.5)},
    {"turn_to": 90.0},
    {"wait": 1.0},
]


@pytest.fixture(scope="module")
def icub():
    return load_robot("icub")


@pytest.fixture(scope="module")
def stage(icub):
    return plan_route(icub, (0.3, 0.5, 0.0), STAGE_ROUTE, stage_support, 12.5)


def _soles(robot, q):
    return robot.frame_transforms(
        q, (robot.description.feet.left_sole, robot.description.feet.right_sole)
    )


def test_stage_route_ends_on_the_platform(icub, stage):
    soles = _soles(icub, stage.q[-1])
    for sole in soles:
        assert sole[2, 3] == pytest.approx(PLATFORM_M, abs=0.005)
        assert 3.2 < sole[0, 3] < 4.0
    pose = stage.robot_pose_true[-1]
    assert pose[2] == pytest.approx(PLATFORM_M, abs=0.005)
    assert pose[3] == pytest.approx(math.pi / 2, abs=1e-3)
    np.testing.assert_allclose(pose[:2], (3.6, 0.5), atol=0.01)
    # every surface was stood on: ground, each step, platform (not the sill: stepped over)
    heights = sorted({round(f.pose[2], 3) for f in stage.footsteps})
    assert heights == [0.0, 0.031, 0.061, 0.092, PLATFORM_M]


def test_stance_feet_stand_flat_on_the_surface(icub, stage):
    worst = 0.0
    for q, stance in zip(stage.q, stage.stance, strict=True):
        soles = _soles(icub, q)
        feet = (0, 1) if stance == Stance.DOUBLE else (int(stance),)
        for foot in feet:
            sole = soles[foot]
            # footprint corners at the sole's height vs. the surface under them
            back, front = icub.description.feet.length_m
            hw = icub.description.feet.half_width_m
            corners = np.array([[back, -hw, 0], [back, hw, 0], [front, -hw, 0], [front, hw, 0]])
            world = corners @ sole[:3, :3].T + sole[:3, 3]
            error = np.abs(world[:, 2] - stage_support(world[:, :2]))
            worst = max(worst, float(error.max()))
    assert worst < 0.005
    assert stage.ik_residual_m.max() < 1e-3


def test_footsteps_are_flat_and_never_straddle_an_edge(icub, stage):
    back, front = icub.description.feet.length_m
    hw = icub.description.feet.half_width_m
    xs, ys = np.meshgrid(np.linspace(back, front, 17), np.linspace(-hw, hw, 5))
    for step in stage.footsteps:
        x, y, z, yaw = step.pose
        c, s = math.cos(yaw), math.sin(yaw)
        pts = np.column_stack(
            [x + c * xs.ravel() - s * ys.ravel(), y + s * xs.ravel() + c * ys.ravel()]
        )
        assert np.ptp(stage_support(pts)) == 0.0
        assert stage_support(pts)[0] == pytest.approx(z)


def test_body_sways_and_bobs_while_walking(icub, stage):
    walking = (stage.times_s > 1.0) & (stage.times_s < 6.0)  # flat ground, straight
    pelvis = stage.q[walking, :3]
    assert 0.003 < np.ptp(pelvis[:, 2]) < 0.03  # bob [m]
    assert 0.02 < np.ptp(pelvis[:, 1]) < 0.08  # lateral sway around y = 0.5 [m]
    assert np.all(np.diff(pelvis[:, 0]) > -1e-9)  # always moving forward or still
    assert set(np.unique(stage.stance[walking])) == {Stance.LEFT, Stance.RIGHT, Stance.DOUBLE}


def test_head_look_sets_camera_direction(icub, stage):
    # first frame: default look (0, -30): camera pitched 30° down, sees the floor ahead
    camera = icub.transform_camera_to_world(stage.q[0])
    assert math.degrees(math.asin(-camera[2, 2])) == pytest.approx(30.0, abs=0.1)
    hit = camera[:3, 3] - camera[:3, 2] * camera[2, 3] / camera[2, 2]
    assert 1.0 < hit[0] - 0.3 < 3.0
    # after the look command (20, -25): head yawed 20° left of the body, pitched 25° down
    i = int(np.argmax((stage.head_look_deg[:, 0] == 20.0) & (stage.stance == Stance.DOUBLE)))
    camera = icub.transform_camera_to_world(stage.q[i])
    yaw = math.degrees(math.atan2(camera[1, 2], camera[0, 2])) - math.degrees(
        stage.robot_pose_true[i, 3]
    )
    # the neck yaws about the pitched head axis: direction = R_pitch(25°) R_yaw(20°) x
    y, p = math.radians(20.0), math.radians(25.0)
    assert yaw == pytest.approx(
        math.degrees(math.atan2(math.sin(y), math.cos(y) * math.cos(p))), abs=0.5
    )
    down = math.degrees(math.asin(-camera[2, 2]))
    assert down == pytest.approx(math.degrees(math.asin(math.cos(y) * math.sin(p))), abs=0.5)


def test_same_inputs_same_trajectory_bit_for_bit(icub, stage):
    again = plan_route(icub, (0.3, 0.5, 0.0), STAGE_ROUTE, stage_support, 12.5)
    np.testing.assert_array_equal(again.q, stage.q)
    np.testing.assert_array_equal(again.robot_pose_true, stage.robot_pose_true)
    assert stage.times_s[1] == pytest.approx(0.08)


def test_robot_pose_is_consistent_with_camera_kinematics(icub, stage):

    for i in range(0, stage.frame_count, 37):
        believed = planar_pose_to_matrix(stage.robot_pose_true[i]) @ icub.transform_camera_to_robot(
            stage.q[i, 7:], int(stage.reference_foot[i])
        )
        np.testing.assert_allclose(believed, icub.transform_camera_to_world(stage.q[i]), atol=1e-4)


@pytest.mark.parametrize(
    ("route", "message"),
    [
        ([{"walk_to": (1, 0), "wait": 1}], "exactly one"),
        ([{}], "exactly one"),
        ([{"wait": -1}], "wait must be > 0"),
        ([{"look": (1,)}], "malformed"),
        ([{"wait": 1.0}, {"walk_to": (math.nan, 0.0)}], r"route\[1\]: walk_to has a malformed"),
        ([{"wait": math.inf}], "2 finite|1 finite"),
        ([{"turn_to": "left"}], r"route\[0\]: turn_to has a malformed value 'left'"),
    ],
)
def test_bad_route_steps_are_rejected(icub, route, message):
    with pytest.raises(RouteError, match=message) as info:
        plan_route(icub, (0.0, 0.0, 0.0), route, flat_support, 12.5, origin="x.toml")
    assert str(info.value).startswith("x.toml: route[")


def test_the_look_range_is_the_neck_joints_limits_in_the_look_convention(icub, talos):
    """iCub's URDF: neck_pitch [-40, 30]° (+ up), neck_yaw ±55°; TALOS: head_1 [-15, 45]° with
    + looking down (so look pitch [-45, 15]°), head_2 ±75°."""
    assert icub.look_range.pitch_deg == (-40.0, 30.0)
    assert icub.look_range.yaw_deg == (-55.0, 55.0)
    assert talos.look_range.pitch_deg == (-45.0, 15.0)
    assert talos.look_range.yaw_deg == (-75.0, 75.0)


@pytest.mark.parametrize(
    ("look", "message"),
    [
        (
            (0.0, -55.0),
            r"pitch -55° beyond the neck's reach: yaw within \[-55, 55\]° \(\+ turns"
            r" left\), pitch within \[-40, 30\]° \(\+ looks up\)$",
        ),
        ((60.0, -30.0), r": yaw 60° beyond the neck's reach"),
        ((-70.0, 31.0), r": yaw -70° and pitch 31° beyond the neck's reach"),
    ],
)
def test_a_look_beyond_the_neck_is_refused_before_planning(icub, look, message):
    """The head used to stop at its limit silently and see less than the route asked."""
    route = [{"wait": 0.5}, {"look": look}]
    with pytest.raises(RouteError, match=message) as info:
        plan_route(icub, (0.0, 0.0, 0.0), route, flat_support, 12.5, origin="x.toml")
    assert str(info.value).startswith("x.toml: route[1] (look ")
    assert "icub's head cannot look there" in str(info.value)


def test_a_look_at_the_neck_limit_is_reached(icub):
    """look = (0, -40), iCub's limit: the camera ends pitched 40° down (the default 30° + 10°)."""
    route = [{"look": (0.0, -40.0)}, {"wait": 0.5}]
    walk = plan_route(icub, (0.0, 0.0, 0.0), route, flat_support, 12.5)
    assert walk.head_look_deg[-1].tolist() == [0.0, -40.0]
    camera = icub.transform_camera_to_world(walk.q[-1])
    assert math.degrees(math.asin(-camera[2, 2])) == pytest.approx(40.0, abs=0.1)


def _tall_block(xy):
    """A 1.3 m high block one can stand on, x in [1.0, 2.0] m: no leg reaches its top."""
    x = np.asarray(xy, dtype=float)[:, 0]
    return np.where((x >= 1.0) & (x <= 2.0), 1.3, 0.0)


def test_an_unreachable_footstep_names_file_step_and_footstep_and_stops_early(icub, monkeypatch):
    configurations = []
    solve = BodyKinematics.configuration

    def counted(self, *args):
        configurations.append(args)
        return solve(self, *args)

    monkeypatch.setattr(BodyKinematics, "configuration", counted)
    route = [{"wait": 0.2}, {"walk_to": (1.5, 0.5)}, {"wait": 600.0}]  # 7600+ frames in all
    with pytest.raises(RouteError) as info:
        plan_route(icub, (0.3, 0.5, 0.0), route, _tall_block, 12.5, origin="tall.toml")
    message = str(info.value)
    assert message.startswith("tall.toml: route[1] (walk_to 1.5, 0.5): the legs cannot reach ")
    assert "footstep at (1.035, 0.568, 1.300) m" in message  # the first foot onto the block
    assert "the other foot stands at z = 0.000 m" in message
    assert "leg IK misses by" in message
    assert len(configurations) < 100  # refused at the first frame that misses, ~6 s in


def test_start_pose_errors_name_the_origin(icub):
    def split_at(y_m):  # 0.1 m higher left of y_m
        return lambda xy: np.where(np.asarray(xy)[:, 1] > y_m, 0.1, 0.0)

    with pytest.raises(RouteError, match=r"^s\.toml: robot start \[0\.0, 0\.5, 0\.0\]: .*edge"):
        plan_route(icub, (0.0, 0.5, 0.0), [], split_at(0.568), 12.5, origin="s.toml")
    with pytest.raises(RouteError) as info:  # each foot flat, but 0.1 m apart in height
        plan_route(icub, (0.0, 0.5, 0.0), [], split_at(0.5), 12.5, origin="s.toml")
    assert str(info.value).startswith(
        "s.toml: the start: the legs cannot reach the feet standing at "
        "LEFT (-0.050, 0.568, 0.100) m and RIGHT (-0.050, 0.432, 0.000) m: leg IK misses by"
    )


def test_frame_budget_of_a_walk():
    budget = FrameBudget(frame_rate_hz=12.5, max_frames=MAX_TRAJECTORY_FRAMES, final_stand_s=0.5)
    assert MAX_TRAJECTORY_FRAMES == 20_000
    assert budget.route_end_s == pytest.approx(19_999 / 12.5 - 0.5)
    assert budget.refusal(2000.0) == (
        "the walk would last 2000.0 s or more, 25001 frames at 12.5 Hz; at most 20000 frames "
        "(1599.9 s at this rate) are allowed"
    )


@pytest.mark.parametrize(
    ("route", "rate_hz", "step", "frames"),
    [
        # a one-hour wait at 100 Hz: refused before the wait is planned (exact)
        ([{"wait": 3600.0}], 100.0, "route[0] (wait 3600)", 360_101),
        # 900 m: refused before planning, by the lower bound (0.3 m per 0.7 s step)
        ([{"walk_to": (900.0, 0.5)}], 12.5, "route[0] (walk_to 900, 0.5)", 26_254),
        # the second wait crosses the budget
        ([{"wait": 1000.0}, {"wait": 1000.0}], 12.5, "route[1] (wait 1000)", 25_013),
        # turns of 180° (24 steps, 16.8 s each): the time of a turn is exact before it is planned
        ([{"turn_to": 180.0}, {"turn_to": 0.0}] * 50, 12.5, "route[95] (turn_to 0)", 20_173),
    ],
)
def test_a_walk_longer_than_the_frame_budget_is_refused_before_it_is_planned(
    icub, route, rate_hz, step, frames
):
    with pytest.raises(RouteError) as info:
        plan_route(icub, (0.0, 0.0, 0.0), route, flat_support, rate_hz, origin="long.toml")
    message = str(info.value)
    assert message.startswith(f"long.toml: {step}: the walk would last ")
    assert f"{frames} frames at {rate_hz:g} Hz; at most 20000 frames" in message


def test_a_walk_longer_than_its_lower_bound_is_refused_once_its_footsteps_are_planned(icub):
    """210 m: at least 489 s by the lower bound (passes), 1633 s once planned (refused)."""
    route = [{"walk_to": (210.0, 0.0)}]
    with pytest.raises(
        RouteError, match=r"^w\.toml: route\[0\] \(walk_to 210, 0\): the walk would last 16"
    ):
        plan_route(icub, (0.0, 0.0, 0.0), route, flat_support, 12.5, origin="w.toml")


def test_bad_parameters_are_rejected():
    with pytest.raises(RouteError, match="step_period_s"):
        GaitParams(step_period_s=0.0)


def test_talos_walks_a_short_route():
    talos = load_robot("talos")
    traj = plan_route(
        talos, (0.0, 0.0, 0.0), [{"walk_to": (0.5, 0.0)}], lambda xy: np.zeros(len(xy)), 12.5
    )
    assert traj.ik_residual_m.max() < 1e-3
    assert traj.robot_pose_true[-1, 0] == pytest.approx(0.5, abs=0.01)


@pytest.fixture(scope="module")
def talos():
    return load_robot("talos")


def _camera_yaw_and_down_deg(camera, robot_yaw_rad):
    yaw = math.degrees(math.atan2(camera[1, 2], camera[0, 2]) - robot_yaw_rad)
    return yaw, math.degrees(math.asin(-camera[2, 2]))


def test_talos_look_maps_to_pan_and_tilt(talos):
    """look = (0, -30): 30° down, straight ahead; (20, -25) as iCub (yaw about the tilted head)."""
    route = [{"wait": 0.5}, {"look": (20.0, -25.0)}, {"wait": 0.5}]
    walk = plan_route(talos, (0.3, 0.5, 40.0), route, flat_support, 12.5)
    yaw, down = _camera_yaw_and_down_deg(
        talos.transform_camera_to_world(walk.q[0]), walk.robot_pose_true[0, 3]
    )
    assert yaw == pytest.approx(0.0, abs=0.1) and down == pytest.approx(30.0, abs=0.1)
    yaw, down = _camera_yaw_and_down_deg(
        talos.transform_camera_to_world(walk.q[-1]), walk.robot_pose_true[-1, 3]
    )
    y, p = math.radians(20.0), math.radians(25.0)
    assert yaw == pytest.approx(
        math.degrees(math.atan2(math.sin(y), math.cos(y) * math.cos(p))), abs=0.1
    )
    assert down == pytest.approx(math.degrees(math.asin(math.cos(y) * math.sin(p))), abs=0.1)


def test_talos_camera_is_outside_its_head(talos):
    """Rays over the whole field of view from the depth camera hit no robot geometry nearby."""

    walk = plan_route(talos, (0.0, 0.0, 0.0), [{"wait": 0.2}], flat_support, 12.5)
    model = mujoco.MjModel.from_xml_path(str(talos.mjcf_path))
    data = mujoco.MjData(model)
    data.qpos[:] = talos.qpos_mujoco(walk.q[0])
    mujoco.mj_kinematics(model, data)
    camera = talos.transform_camera_to_world(walk.q[0])
    u, v = np.meshgrid(np.linspace(-1, 1, 9), np.linspace(-1, 1, 9))
    half_w, half_h = math.tan(math.radians(23.5)), math.tan(math.radians(19.5))
    rays_camera = np.stack([u * half_w, v * half_h, np.ones_like(u)], -1).reshape(-1, 3)
    rays_world = rays_camera @ camera[:3, :3].T
    rays_world /= np.linalg.norm(rays_world, axis=1, keepdims=True)
    geom = np.zeros(1, np.int32)
    distances = np.array(
        [mujoco.mj_ray(model, data, camera[:3, 3], ray, None, 1, -1, geom) for ray in rays_world]
    )
    hits = distances[distances >= 0.0]  # -1: the ray meets no robot geometry
    assert hits.size == 0 or hits.min() > 0.3, hits.min()


def test_stage_scenario_route_is_about_a_minute_and_ends_on_the_platform(icub):
    scenario = load_scenario("stage")
    walk = plan_route(
        icub,
        scenario.robot.start,
        scenario.route,
        SceneTruth.from_scenario(scenario, 0.0).support_height_m,
        scenario.frame_rate_hz,
    )
    assert 60.0 < walk.duration_s < 70.0  # 66.5 s
    soles = icub.frame_transforms(
        walk.q[-1], (icub.description.feet.left_sole, icub.description.feet.right_sole)
    )
    for sole in soles:
        assert sole[2, 3] == pytest.approx(PLATFORM_M, abs=0.005)
    assert walk.robot_pose_true[-1, 0] > 3.2  # on the platform (x from 3.2 to 4.0 m)
    # it looked back over the stage: facing -x at the end
    assert abs(math.cos(walk.robot_pose_true[-1, 3]) + 1.0) < 1e-3
