"""The walk sampled at the frame rate: pelvis placement and whole-body configurations per frame.

No balance controller: the feet are placed flat on the surfaces the ground truth reports, the
legs follow the feet by inverse kinematics, the pelvis follows the feet with lateral sway and
vertical bob, the torso stays upright, the neck follows ``look`` commands.

Frames: world (z up); feet are given by their sole frames; the robot frame R is
`fogsim.robot.kinematics.Robot.robot_frame_in_world` with the stance foot as reference (left in
DOUBLE).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fogsim.errors import RouteError
from fogsim.robot.kinematics import Robot, Stance
from fogsim.robot.planar import mean_angle
from fogsim.robot.walking.body import BodyKinematics
from fogsim.robot.walking.footsteps import Footstep, FootstepPlanner, SupportHeightFn
from fogsim.robot.walking.gait import GaitParams
from fogsim.robot.walking.limits import MAX_IK_RESIDUAL_M, MAX_TRAJECTORY_FRAMES
from fogsim.robot.walking.route import (
    FrameBudget,
    RouteCommand,
    RouteStepInput,
    apply_route,
    route_commands,
)
from fogsim.robot.walking.timeline import Segment, SegmentSample, sample_segment


@dataclass(frozen=True)
class Trajectory:
    """The whole walk sampled at the frame rate.

    Attributes:
        times_s: (T,) sample times [s].
        q: (T, nq) pinocchio configurations (free flyer first).
        robot_pose_true: (T, 4) true pose of R (x, y, z [m], yaw [rad]).
        stance: (T,) `Stance` values (LEFT/RIGHT single support, DOUBLE).
        reference_foot: (T,) LEFT/RIGHT: the foot R and the odometry are anchored to.
        head_look_deg: (T, 2) commanded head (yaw, pitch) [deg].
        footsteps: The footstep plan, in order.
        ik_residual_m: (T,) largest leg IK position residual [m].
    """

    times_s: NDArray[np.float64]
    q: NDArray[np.float64]
    robot_pose_true: NDArray[np.float64]
    stance: NDArray[np.int8]
    reference_foot: NDArray[np.int8]
    head_look_deg: NDArray[np.float64]
    footsteps: tuple[Footstep, ...]
    ik_residual_m: NDArray[np.float64]

    @property
    def frame_count(self) -> int:
        """Number of samples T."""
        return int(self.times_s.size)

    @property
    def duration_s(self) -> float:
        """Time of the last sample [s]."""
        return float(self.times_s[-1]) if self.times_s.size else 0.0


def plan_route(
    robot: Robot,
    start_pose_xy_yaw: ArrayLike,
    route_steps: Sequence[RouteStepInput],
    support_height_m: SupportHeightFn,
    frame_rate_hz: float,
    params: GaitParams | None = None,
    origin: str = "plan_route",
) -> Trajectory:
    """Plan a kinematic walk along a route and sample it at the frame rate.

    Work is refused as early as it can be: the route's steps are checked before planning, each
    step's duration before the step is planned (the walk may have at most
    :data:`~fogsim.robot.walking.limits.MAX_TRAJECTORY_FRAMES` frames), and the leg IK stops at
    the first frame whose footstep the legs cannot reach.

    Args:
        robot: The humanoid (`fogsim.robot.model.load_robot`).
        start_pose_xy_yaw: (x [m], y [m], yaw [deg]) of the robot frame at the start.
        route_steps: Route steps (see `fogsim.robot.walking.route`).
        support_height_m: Height [m] of the highest standing surface at (N, 2) world xy.
        frame_rate_hz: Sample rate of the trajectory [Hz].
        params: Gait parameters (defaults suit iCub).
        origin: How errors name the route's origin (the scenario file).

    Returns:
        The trajectory; deterministic for the same inputs.

    Raises:
        RouteError: A malformed route step, a ``look`` beyond the neck's joint limits
            (`Robot.look_range`), no flat footstep where the route goes, a walk of
            more than ``MAX_TRAJECTORY_FRAMES`` frames, or a footstep the legs cannot reach;
            the message names ``origin``, the route step and the footstep.
    """
    params = params or GaitParams()
    if not 0.0 < frame_rate_hz < math.inf:
        raise RouteError(f"{origin}: frame_rate_hz must be finite and > 0, got {frame_rate_hz}")
    start = np.asarray(start_pose_xy_yaw, dtype=np.float64).reshape(-1)
    if start.size != 3 or not np.all(np.isfinite(start)):
        raise RouteError(f"{origin}: start pose must be (x, y, yaw_deg), got {start_pose_xy_yaw!r}")
    commands = route_commands(route_steps, origin)
    reach = robot.look_range
    for command in commands:
        refusal = reach.refusal(*command.values) if command.kind == "look" else None
        if refusal is not None:  # the head would stop at its limit and see less than asked
            raise RouteError(
                f"{origin}: {command}: {robot.name}'s head cannot look there: {refusal}"
            )
    budget = FrameBudget(frame_rate_hz, MAX_TRAJECTORY_FRAMES, params.look_transition_s)
    planner = FootstepPlanner(robot, params, support_height_m)
    try:
        planner.start(start[0], start[1], math.radians(start[2]))
    except RouteError as error:
        raise RouteError(f"{origin}: robot start {start.tolist()}: {error}") from error
    planner.hold(params.look_transition_s)  # settle: stand still, head at the default look
    apply_route(planner, commands, budget, origin)
    planner.hold(params.look_transition_s)
    segments = planner.segments
    duration = planner.time_s
    times = np.arange(0.0, duration + 1e-9, 1.0 / frame_rate_hz)
    if times.size > budget.max_frames:
        raise RouteError(f"{origin}: {budget.refusal(duration)}")
    body = BodyKinematics(robot, params)
    q_all = np.empty((times.size, robot.nq))
    pose_true = np.empty((times.size, 4))
    stance = np.empty(times.size, dtype=np.int8)
    looks = np.empty((times.size, 2))
    residuals = np.empty(times.size)
    seg_index = 0
    reach_m = body.leg_length_m - params.leg_reach_margin_m
    for i, t in enumerate(times):
        while seg_index + 1 < len(segments) and t >= segments[seg_index + 1].start_s - 1e-12:
            seg_index += 1
        sample = sample_segment(segments[seg_index], float(t), params.double_support_fraction)
        pelvis_xy, pelvis_z = _pelvis_position(sample, robot, params, reach_m)
        yaw = mean_angle(sample.left[3], sample.right[3])
        swing = None if sample.support is None else Stance(1 - int(sample.support))
        q, residual = body.configuration(
            sample.left, sample.right, pelvis_xy, pelvis_z, yaw, sample.look_deg, swing
        )
        if residual > MAX_IK_RESIDUAL_M:
            raise RouteError(
                _unreachable(origin, segments[seg_index], commands, float(t), residual)
            )
        q_all[i] = q
        residuals[i] = residual
        stance[i] = int(Stance.DOUBLE if sample.support is None else sample.support)
        looks[i] = sample.look_deg
    reference = np.where(stance == Stance.RIGHT, Stance.RIGHT, Stance.LEFT).astype(np.int8)
    for i in range(times.size):
        pose_true[i] = robot.robot_frame_in_world(q_all[i], Stance(int(reference[i])))
    return Trajectory(
        times_s=times,
        q=q_all,
        robot_pose_true=pose_true,
        stance=stance,
        reference_foot=reference,
        head_look_deg=looks,
        footsteps=tuple(planner.footsteps),
        ik_residual_m=residuals,
    )


def _unreachable(
    origin: str,
    segment: Segment,
    commands: Sequence[RouteCommand],
    time_s: float,
    residual_m: float,
) -> str:
    """Why the walk is refused: which route step, which footstep the legs cannot reach."""
    step = "the start" if segment.route_step is None else str(commands[segment.route_step])
    if segment.swing is None:
        feet = {Stance.LEFT: segment.left_to, Stance.RIGHT: segment.right_to}
        what = "the feet standing at " + " and ".join(
            f"{foot.name} {_xyz(pose)}" for foot, pose in feet.items()
        )
    else:
        target = segment.left_to if segment.swing == Stance.LEFT else segment.right_to
        other = segment.right_to if segment.swing == Stance.LEFT else segment.left_to
        what = (
            f"the {segment.swing.name} footstep at {_xyz(target)} (the other foot stands at "
            f"z = {other[2]:.3f} m)"
        )
    return (
        f"{origin}: {step}: the legs cannot reach {what}: leg IK misses by "
        f"{residual_m * 1e3:.1f} mm at t = {time_s:.2f} s (allowed: "
        f"{MAX_IK_RESIDUAL_M * 1e3:g} mm); a step may rise or drop only as far as the legs reach"
    )


def _xyz(pose: NDArray[np.float64]) -> str:
    """``(x, y, z) m`` of a sole pose, to the millimetre."""
    return f"({pose[0]:.3f}, {pose[1]:.3f}, {pose[2]:.3f}) m"


def _pelvis_position(
    sample: SegmentSample, robot: Robot, params: GaitParams, reach_m: float
) -> tuple[NDArray[np.float64], float]:
    """Root (x, y) and z [m] in the world for the feet of a sample.

    Between the foot centres, swayed towards the stance foot and bobbing up during a swing, at
    the nominal height above the mean surface, but low enough for both legs to reach their soles
    (``reach_m``, hip to sole).
    """
    offset = robot.description.feet.center_offset_m
    centres = [
        p[:2] + offset * np.array([math.cos(p[3]), math.sin(p[3])])
        for p in (sample.left, sample.right)
    ]
    pelvis_xy = 0.5 * (centres[0] + centres[1])
    bob = 0.0
    if sample.support is not None:
        towards = centres[0 if sample.support == Stance.LEFT else 1] - pelvis_xy
        norm = float(np.linalg.norm(towards))
        if norm > 1e-9:
            sway = params.sway_m * math.sin(math.pi * sample.phase) * towards / norm
            pelvis_xy = pelvis_xy + sway
        bob = params.bob_m * math.sin(math.pi * sample.phase)
    nominal = robot.description.legs.pelvis_height_m
    pelvis_z = nominal + 0.5 * (sample.left_surface_m + sample.right_surface_m) + bob
    for pose in (sample.left, sample.right):  # keep both legs short of full extension
        d = float(np.linalg.norm(pose[:2] - pelvis_xy))
        pelvis_z = min(pelvis_z, pose[2] + math.sqrt(max(reach_m * reach_m - d * d, 0.0)))
    return pelvis_xy, pelvis_z
