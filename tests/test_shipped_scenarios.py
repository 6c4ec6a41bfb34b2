"""The shipped courses ``stage_zigzag``, ``room`` and ``talos_course`` are what they say they are.

They are data, so these tests check what they were built for: the heights, treads and turns
they were given (hand-computed), that the robot walks their routes, that every obstacle lies
whole inside the camera's 47° × 39° view from nearby at some frame (the view frustum of the true
camera pose; occlusion is not modelled), that the room's rock is taken away while the standing
robot looks at it, and that TALOS's sill and treads sit where its footstep planner's limits are.
"""

from __future__ import annotations

import itertools
import math
from functools import cache

import numpy as np
import pytest
from numpy.typing import NDArray

from fogsim.config import Scenario, load_scenario
from fogsim.config.schema import SceneObject
from fogsim.errors import RouteError
from fogsim.robot import Stance, Trajectory, load_robot, plan_route
from fogsim.sim.camera.intrinsics import camera_intrinsics
from fogsim.world import SceneTruth

COURSES = ("stage_zigzag", "room", "talos_course")
PAPER_HEIGHTS_MM = {38, 31, 61, 92, 122}
"""The paper's stage (Sec. V): sill, three steps, platform [mm]."""
NEAR_M = {"stage_zigzag": 1.5, "room": 1.5, "talos_course": 2.0}
"""How near [m, horizontal, camera to object centre] each obstacle must be seen whole: iCub's
camera (~0.85 m up) sees the floor from ~0.6 m, TALOS's (~1.45 m) from ~0.7 m at its steepest."""


def plan(scenario: Scenario) -> Trajectory:
    """The scenario's walk, planned on its world at the start (as the simulation does)."""
    truth = SceneTruth.from_scenario(scenario, 0.0)
    robot = load_robot(scenario.robot.model)
    return plan_route(
        robot,
        scenario.robot.start,
        scenario.route,
        truth.support_height_m,
        scenario.frame_rate_hz,
        origin=scenario.origin,
    )


@cache
def course(name: str) -> tuple[Scenario, Trajectory, NDArray[np.float64]]:
    """A shipped course, its walk and the true camera pose in the world per frame (T, 4, 4)."""
    scenario = load_scenario(name)
    trajectory = plan(scenario)
    robot = load_robot(scenario.robot.model)
    transforms_camera_to_world = np.stack(
        [robot.transform_camera_to_world(q, "head_camera") for q in trajectory.q]
    )
    return scenario, trajectory, transforms_camera_to_world


def top_corners_world(obj: SceneObject) -> NDArray[np.float64]:
    """The four corners of a box's top (its highest point's height) in the world, (4, 3) [m]."""
    half_x, half_y = 0.5 * obj.size[0], 0.5 * obj.size[1]
    corners_object = np.array(
        [[-half_x, -half_y], [half_x, -half_y], [half_x, half_y], [-half_x, half_y]]
    )
    c, s = math.cos(math.radians(obj.yaw_deg)), math.sin(math.radians(obj.yaw_deg))
    xy = corners_object @ np.array([[c, s], [-s, c]]) + np.asarray(obj.center)
    return np.column_stack([xy, np.full(4, obj.top_m)])


def whole_in_view(
    scenario: Scenario, transforms_camera_to_world: NDArray[np.float64], points_world: NDArray
) -> NDArray[np.bool_]:
    """Per frame: every point projects inside the image, in front of the camera, (T,)."""
    intrinsics = camera_intrinsics(scenario.camera)
    rotations = transforms_camera_to_world[:, :3, :3]
    offsets = points_world[None, :, :] - transforms_camera_to_world[:, None, :3, 3]
    points_camera = np.einsum("tij,tpi->tpj", rotations, offsets)  # R^T (p - t)
    depth = points_camera[..., 2]
    in_front = depth > 0.0
    safe_depth = np.where(in_front, depth, 1.0)
    u = intrinsics.fx * points_camera[..., 0] / safe_depth + intrinsics.cx
    v = intrinsics.fy * points_camera[..., 1] / safe_depth + intrinsics.cy
    inside = (
        in_front
        & (u >= -0.5)
        & (u <= intrinsics.width - 0.5)
        & (v >= -0.5)
        & (v <= intrinsics.height - 0.5)
    )
    return inside.all(axis=1)


def leg_headings_deg(scenario: Scenario) -> list[float]:
    """Heading [deg] of each ``walk_to`` leg, from the start through the waypoints in order."""
    position = np.asarray(scenario.robot.start[:2])
    headings = []
    for step in scenario.route:
        if step.walk_to is not None:
            offset = np.asarray(step.walk_to) - position
            headings.append(math.degrees(math.atan2(offset[1], offset[0])))
            position = np.asarray(step.walk_to)
    return headings


def test_stage_zigzag_has_other_heights_and_a_staircase_of_wide_treads():
    scenario = load_scenario("stage_zigzag")
    heights_mm = {o.name: round(o.top_m * 1000, 6) for o in scenario.objects if o.walkable}
    assert heights_mm == {"sill": 45, "step_1": 45, "step_2": 70, "step_3": 95, "platform": 125}
    assert not set(heights_mm.values()) & PAPER_HEIGHTS_MM
    stairs = [scenario.object(n) for n in ("step_1", "step_2", "step_3", "platform")]
    for lower, upper in itertools.pairwise(stairs):
        # each tread ends where the next one begins, and the treads are at least 0.25 m deep
        assert lower.center[0] + lower.size[0] / 2 == pytest.approx(
            upper.center[0] - upper.size[0] / 2, abs=1e-9
        )
        assert lower.size[0] >= 0.25
    assert all(o.surface == "rough" for o in scenario.objects if not o.walkable)


def test_stage_zigzag_route_turns_31_to_39_degrees_each_way_between_the_boxes():
    headings = leg_headings_deg(load_scenario("stage_zigzag"))
    # legs: start (-0.3, 0.5) -> (0.4, 0.64) -> (1.2, 0.36) -> (2.0, 0.64) -> (2.4, 0.5), then
    # straight along the stage; atan(0.14 / 0.7) = 11.31°, atan(0.28 / 0.8) = 19.29°
    assert headings == pytest.approx([11.31, -19.29, 19.29, -19.29, 0.0, 0.0], abs=0.01)
    turns = np.diff(headings)
    assert turns[:4] == pytest.approx([-30.60, 38.58, -38.58, 19.29], abs=0.01)


@pytest.mark.parametrize("name", COURSES)
def test_every_obstacle_is_whole_in_view_from_nearby(name):
    scenario, _, transforms_camera_to_world = course(name)
    camera_xy = transforms_camera_to_world[:, :2, 3]
    for obj in scenario.objects:
        if obj.walkable:
            continue
        near = np.linalg.norm(camera_xy - np.asarray(obj.center), axis=1) <= NEAR_M[name]
        seen = whole_in_view(scenario, transforms_camera_to_world, top_corners_world(obj))
        assert np.count_nonzero(near & seen) >= 5, obj.name  # several frames, not a glimpse


def test_room_rock_is_taken_away_while_the_standing_robot_looks_at_it():
    scenario, trajectory, transforms_camera_to_world = course("room")
    (event,) = scenario.events
    assert (event.kind, event.target) == ("remove", "rock_gone")
    rock = scenario.object(event.target)
    seen = whole_in_view(scenario, transforms_camera_to_world, top_corners_world(rock))
    # two seconds before to three seconds after the event: standing still, the rock in view
    watching = np.abs(trajectory.times_s - event.at - 0.5) <= 2.5
    assert np.all(seen[watching])
    assert np.all(trajectory.stance[watching] == Stance.DOUBLE)
    poses = trajectory.robot_pose_true[watching]
    assert np.ptp(poses, axis=0) == pytest.approx(np.zeros(4), abs=1e-9)
    # the route never crosses the rock's place (planned on the world with the rock in it)
    footsteps_xy = np.array([f.pose[:2] for f in trajectory.footsteps])
    assert np.min(np.linalg.norm(footsteps_xy - np.asarray(rock.center), axis=1)) > 0.2


def test_room_table_is_a_low_flat_hanging_top_and_every_rock_is_rough():
    scenario = load_scenario("room")
    table = scenario.object("low_table")
    assert (table.base, table.top_m, table.surface) == (0.27, pytest.approx(0.3), "flat")
    rocks = [o for o in scenario.objects if o.name.startswith("rock_")]
    assert len(rocks) == 6 and all(o.surface == "rough" and o.base == 0.0 for o in rocks)
    assert scenario.object("sill").walkable and scenario.object("sill").top_m == 0.04


def test_talos_course_sill_and_treads_are_within_the_footstep_planners_limits():
    scenario = load_scenario("talos_course")
    assert scenario.robot.model == "talos"
    trajectory = course("talos_course")[1]
    assert trajectory.robot_pose_true[-1, 2] == pytest.approx(0.32, abs=1e-4)  # on the platform
    # A sill is stepped over with a whole foot (0.2 m + 2 x 5 mm margin) before and after it at
    # most max_step_m = 0.3 m apart: 8 cm passes (the course has 6 cm), 10 cm does not.
    wider = scenario.with_overrides(["objects.sill.size=[0.10, 1.4, 0.06]"])
    with pytest.raises(RouteError, match="no flat footstep"):
        plan(wider)
    plan(scenario.with_overrides(["objects.sill.size=[0.08, 1.4, 0.06]"]))
    # The paper's staircase (0.2 m treads) has no room for TALOS's foot; this course's 0.3 m do.
    with pytest.raises(RouteError, match="no flat footstep"):
        plan(load_scenario("stairs").with_overrides(["robot.model=talos"]))
