"""Kinematic walking: a scripted route becomes footsteps over the terrain, then joint trajectories.

No balance controller: the feet are placed flat on the surfaces the ground truth reports
(``support_height_m``), the legs follow the feet by pinocchio inverse kinematics (CLIK on each
leg's six joints, warm started), the pelvis follows the feet with lateral sway and vertical bob,
the torso stays upright, the neck follows ``look`` commands.

Route steps (``scenario.route``): mappings or objects with exactly one of
``walk_to: (x [m], y [m])``, ``turn_to: yaw [deg]``, ``look: (yaw [deg], pitch [deg])`` (head
relative to the body, positive yaw = left, negative pitch = down) or ``wait: seconds``.

Footstep rule: each footstep puts the whole sole (plus a margin) on one surface. The planner
tries the nominal step first, then shorter ones, then longer ones up to ``max_step_m``, so the
robot steps over the sill and takes every stair tread with both feet when it must.

Frames: world (z up); feet are given by their sole frames; the robot frame R is
`fogsim.robot.model.Robot.robot_frame_in_world` with the stance foot as reference (left in DOUBLE).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from fogsim.errors import RouteError
from fogsim.robot.model import Robot, Stance

SupportHeightFn = Callable[[NDArray[np.float64]], NDArray[np.float64]]


@dataclass(frozen=True)
class GaitParams:
    """Parameters of the kinematic gait.

    Attributes:
        step_length_m: Nominal advance of a foot ahead of the other [m].
        max_step_m: Longest allowed advance of a foot ahead of the other [m].
        min_progress_m: Smallest advance of a swing foot over its previous position [m].
        step_period_s: Duration of one step (double support + swing) [s].
        double_support_fraction: Fraction of the step period with both feet down.
        swing_clearance_m: Sole clearance above the highest surface under the swing path [m].
        turn_step_deg: Largest yaw change per pair of steps when turning in place [deg].
        heading_tolerance_deg: ``walk_to`` turns in place first if the heading differs more.
        flat_tolerance_m: Footprint height spread that still counts as one surface [m].
        footprint_margin_m: Margin added around the sole when checking flatness [m].
        sway_m: Lateral pelvis sway towards the stance foot [m].
        bob_m: Vertical pelvis bob during swing [m].
        leg_reach_margin_m: The pelvis stays this much below full leg extension [m].
        look_default_deg: Head (yaw, pitch) before any ``look`` command [deg].
        look_transition_s: Time a ``look`` command takes (the robot stands) [s].
        ik_tolerance_m: Leg IK residual (position) to reach [m].
        ik_max_iterations: CLIK iterations per leg and frame.
    """

    step_length_m: float = 0.09
    max_step_m: float = 0.3
    min_progress_m: float = 0.03
    step_period_s: float = 0.7
    double_support_fraction: float = 0.25
    swing_clearance_m: float = 0.03
    turn_step_deg: float = 15.0
    heading_tolerance_deg: float = 3.0
    flat_tolerance_m: float = 0.002
    footprint_margin_m: float = 0.005
    sway_m: float = 0.02
    bob_m: float = 0.006
    leg_reach_margin_m: float = 0.012
    look_default_deg: tuple[float, float] = (0.0, -30.0)
    look_transition_s: float = 0.5
    ik_tolerance_m: float = 1e-6
    ik_max_iterations: int = 50

    def __post_init__(self) -> None:
        checks = {
            "step_length_m": 0.0 < self.step_length_m <= self.max_step_m,
            "min_progress_m": 0.0 < self.min_progress_m <= self.step_length_m,
            "step_period_s": self.step_period_s > 0.0,
            "double_support_fraction": 0.0 <= self.double_support_fraction < 1.0,
            "swing_clearance_m": self.swing_clearance_m > 0.0,
            "turn_step_deg": 0.0 < self.turn_step_deg <= 45.0,
            "look_transition_s": self.look_transition_s > 0.0,
            "ik_tolerance_m": self.ik_tolerance_m > 0.0,
        }
        for name, ok in checks.items():
            if not ok:
                raise RouteError(f"GaitParams.{name}={getattr(self, name)!r} is out of range")


@dataclass(frozen=True)
class Footstep:
    """One planned footstep: sole pose (x, y, z [m], yaw [rad]) in the world."""

    foot: Stance
    pose: tuple[float, float, float, float]


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
    footsteps: tuple[Footstep, ...] = field(default=())
    ik_residual_m: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))

    @property
    def frame_count(self) -> int:
        """Number of samples T."""
        return int(self.times_s.size)

    @property
    def duration_s(self) -> float:
        """Time of the last sample [s]."""
        return float(self.times_s[-1]) if self.times_s.size else 0.0


# ====================================================================== footstep planning


def _smoothstep(x: float) -> float:
    x = min(1.0, max(0.0, x))
    return x * x * (3.0 - 2.0 * x)


def _wrap(angle: float) -> float:
    return math.atan2(math.sin(angle), math.cos(angle))


@dataclass
class _Segment:
    """A stretch of the timeline: a step of one foot, or standing still."""

    start_s: float
    duration_s: float
    swing: Stance | None  # None: both feet stand
    left_from: NDArray[np.float64]
    left_to: NDArray[np.float64]
    right_from: NDArray[np.float64]
    right_to: NDArray[np.float64]
    apex_z: float
    look_from: NDArray[np.float64]
    look_to: NDArray[np.float64]


class _Planner:
    """Turns route steps into timeline segments (foot poses are sole origins in the world)."""

    def __init__(self, robot: Robot, params: GaitParams, support_height_m: SupportHeightFn) -> None:
        self.robot = robot
        self.params = params
        self.support = support_height_m
        cfg = robot.config
        self.centre_offset = cfg.sole_center_offset_m
        back, front = cfg.foot_length_m
        margin = params.footprint_margin_m
        xs = np.linspace(back - margin, front + margin, 9)
        ys = np.linspace(-cfg.foot_half_width_m - margin, cfg.foot_half_width_m + margin, 3)
        gx, gy = np.meshgrid(xs, ys)
        self.footprint_sole = np.stack([gx.ravel(), gy.ravel()], axis=1)  # in the sole frame
        soles = robot.frame_transforms(robot.neutral(), (cfg.left_sole, cfg.right_sole))
        self.half_width = 0.5 * float(np.linalg.norm(soles[0][:2, 3] - soles[1][:2, 3]))
        self.segments: list[_Segment] = []
        self.footsteps: list[Footstep] = []
        self.time_s = 0.0
        self.look = np.asarray(params.look_default_deg, dtype=np.float64)
        self.left = np.zeros(4)
        self.right = np.zeros(4)

    # -------------------------------------------------------------- terrain queries
    def _footprint_heights(self, sole_pose: ArrayLike) -> NDArray[np.float64]:
        x, y, _, yaw = (float(v) for v in sole_pose)
        c, s = math.cos(yaw), math.sin(yaw)
        pts = self.footprint_sole
        world = np.column_stack(
            [x + c * pts[:, 0] - s * pts[:, 1], y + s * pts[:, 0] + c * pts[:, 1]]
        )
        return np.asarray(self.support(world), dtype=np.float64).reshape(-1)

    def _flat_height(self, sole_pose: ArrayLike) -> float | None:
        heights = self._footprint_heights(sole_pose)
        if float(heights.max() - heights.min()) > self.params.flat_tolerance_m:
            return None
        return float(np.median(heights))

    def _sole_at(self, centre_xy: ArrayLike, yaw: float, side: Stance) -> NDArray[np.float64]:
        """Sole-origin pose of a foot whose centre is beside ``centre_xy`` (robot centre)."""
        c, s = math.cos(yaw), math.sin(yaw)
        lateral = self.half_width if side == Stance.LEFT else -self.half_width
        cx = centre_xy[0] - s * lateral - c * self.centre_offset
        cy = centre_xy[1] + c * lateral - s * self.centre_offset
        return np.array([cx, cy, 0.0, yaw])

    def _centre(self) -> NDArray[np.float64]:
        def foot_centre(p: NDArray[np.float64]) -> NDArray[np.float64]:
            return p[:2] + self.centre_offset * np.array([math.cos(p[3]), math.sin(p[3])])

        return 0.5 * (foot_centre(self.left) + foot_centre(self.right))

    def _heading(self) -> float:
        a, b = self.left[3], self.right[3]
        return a + 0.5 * _wrap(b - a)

    # -------------------------------------------------------------- segments
    def start(self, x: float, y: float, yaw: float) -> None:
        for side in (Stance.LEFT, Stance.RIGHT):
            pose = self._sole_at((x, y), yaw, side)
            height = self._flat_height(pose)
            if height is None:
                raise RouteError(f"start pose ({x}, {y}) puts the {side.name} foot on an edge")
            pose[2] = height
            if side == Stance.LEFT:
                self.left = pose
            else:
                self.right = pose

    def _hold(self, duration_s: float, look_to: NDArray[np.float64] | None = None) -> None:
        target = self.look if look_to is None else look_to
        self.segments.append(
            _Segment(
                self.time_s, duration_s, None, self.left.copy(), self.left.copy(),
                self.right.copy(), self.right.copy(), 0.0, self.look.copy(), target.copy(),
            )
        )  # fmt: skip
        self.time_s += duration_s
        self.look = target.copy()

    def _step(self, foot: Stance, target: NDArray[np.float64]) -> None:
        start = self.left if foot == Stance.LEFT else self.right
        # highest surface under the swing path (footprint swept along the straight line)
        highest = max(start[2], target[2])
        for f in np.linspace(0.0, 1.0, 9):
            pose = start + f * (target - start)
            pose[3] = start[3] + f * _wrap(target[3] - start[3])
            highest = max(highest, float(self._footprint_heights(pose).max()))
        new_left = target.copy() if foot == Stance.LEFT else self.left.copy()
        new_right = target.copy() if foot == Stance.RIGHT else self.right.copy()
        self.segments.append(
            _Segment(
                self.time_s, self.params.step_period_s, foot, self.left.copy(), new_left,
                self.right.copy(), new_right, highest + self.params.swing_clearance_m,
                self.look.copy(), self.look.copy(),
            )
        )  # fmt: skip
        self.time_s += self.params.step_period_s
        self.left, self.right = new_left, new_right
        self.footsteps.append(Footstep(foot, tuple(float(v) for v in target)))

    def _place(self, foot: Stance, centre_xy: ArrayLike, yaw: float) -> NDArray[np.float64]:
        pose = self._sole_at(centre_xy, yaw, foot)
        height = self._flat_height(pose)
        if height is None:
            raise RouteError(
                f"no flat place for the {foot.name} foot near ({centre_xy[0]:.3f}, "
                f"{centre_xy[1]:.3f}) while turning; turn on flat ground"
            )
        pose[2] = height
        return pose

    # -------------------------------------------------------------- route commands
    def turn_to(self, yaw: float) -> None:
        heading = self._heading()
        delta = _wrap(yaw - heading)
        if abs(delta) < 1e-9:
            return
        n = max(1, math.ceil(abs(delta) / math.radians(self.params.turn_step_deg)))
        centre = self._centre()
        first, second = (Stance.LEFT, Stance.RIGHT) if delta > 0 else (Stance.RIGHT, Stance.LEFT)
        for i in range(1, n + 1):
            new_yaw = heading + delta * i / n
            for foot in (first, second):
                self._step(foot, self._place(foot, centre, new_yaw))

    def walk_to(self, x: float, y: float) -> None:
        centre = self._centre()
        offset = np.array([x, y]) - centre
        distance = float(np.linalg.norm(offset))
        if distance < 1e-6:
            return
        yaw = math.atan2(offset[1], offset[0])
        if abs(_wrap(yaw - self._heading())) > math.radians(self.params.heading_tolerance_deg):
            self.turn_to(yaw)
            centre = self._centre()
            offset = np.array([x, y]) - centre
            distance = float(np.linalg.norm(offset))
            yaw = math.atan2(offset[1], offset[0])
        direction = np.array([math.cos(yaw), math.sin(yaw)])
        # keep both feet's yaw aligned with the walking direction from the first step on
        along = {Stance.LEFT: 0.0, Stance.RIGHT: 0.0}
        p = self.params
        foot = Stance.LEFT
        for _ in range(10_000):
            other = Stance.RIGHT if foot == Stance.LEFT else Stance.LEFT
            if along[foot] >= distance - 1e-9 and along[other] >= distance - 1e-9:
                break
            s_other = along[other]
            lowest = max(along[foot] + p.min_progress_m, s_other - 0.02)
            nominal = min(s_other + p.step_length_m, distance)
            farthest = min(s_other + p.max_step_m, distance)
            if nominal < lowest:
                nominal = min(lowest, distance)
            candidates = list(np.arange(nominal, lowest - 1e-9, -0.005))
            candidates += list(np.arange(nominal + 0.005, farthest + 1e-9, 0.005))
            if farthest >= distance - 1e-12 and nominal < distance:
                candidates.append(distance)
            placed = self._first_flat(foot, centre, direction, yaw, candidates)
            if placed is None and farthest >= distance - 1e-12:
                # the goal itself is not flat: stop beside the other foot, short of the goal
                if abs(along[foot] - s_other) < 1e-9:
                    break
                placed = self._first_flat(foot, centre, direction, yaw, [s_other])
                distance = s_other
            if placed is None:
                raise RouteError(
                    f"no flat footstep for the {foot.name} foot between "
                    f"{(centre + lowest * direction).round(3).tolist()} and "
                    f"{(centre + farthest * direction).round(3).tolist()} on the way to ({x}, {y})"
                )
            along[foot] = placed[0]
            self._step(foot, placed[1])
            foot = other
        else:  # pragma: no cover - guarded by min_progress_m
            raise RouteError(f"walk_to ({x}, {y}) did not converge")

    def _first_flat(
        self,
        foot: Stance,
        centre: NDArray[np.float64],
        direction: NDArray[np.float64],
        yaw: float,
        candidates: Sequence[float],
    ) -> tuple[float, NDArray[np.float64]] | None:
        """First along-track position whose footprint is flat, with the sole pose there."""
        for s in candidates:
            pose = self._sole_at(centre + s * direction, yaw, foot)
            height = self._flat_height(pose)
            if height is not None:
                pose[2] = height
                return float(s), pose
        return None

    def look_at(self, yaw_deg: float, pitch_deg: float) -> None:
        self._hold(self.params.look_transition_s, np.array([yaw_deg, pitch_deg], dtype=float))

    def wait(self, seconds: float) -> None:
        self._hold(seconds)


def _route_field(step: Any, key: str) -> Any:
    if isinstance(step, Mapping):
        return step.get(key)
    return getattr(step, key, None)


_ROUTE_KEYS = ("walk_to", "turn_to", "look", "wait")


def _apply_route(planner: _Planner, route_steps: Sequence[Any]) -> None:
    for index, step in enumerate(route_steps):
        present = {k: _route_field(step, k) for k in _ROUTE_KEYS}
        present = {k: v for k, v in present.items() if v is not None}
        if len(present) != 1:
            raise RouteError(
                f"route step {index} must have exactly one of {', '.join(_ROUTE_KEYS)}; "
                f"got {sorted(present) or 'none'}"
            )
        ((key, value),) = present.items()
        try:
            if key == "walk_to":
                x, y = (float(v) for v in value)
                planner.walk_to(x, y)
            elif key == "turn_to":
                planner.turn_to(math.radians(float(value)))
            elif key == "look":
                yaw, pitch = (float(v) for v in value)
                planner.look_at(yaw, pitch)
            else:
                seconds = float(value)
                if not seconds > 0.0:
                    raise RouteError(f"route step {index}: wait must be > 0 s, got {value}")
                planner.wait(seconds)
        except (TypeError, ValueError) as error:
            if isinstance(error, RouteError):
                raise
            raise RouteError(
                f"route step {index}: {key} has a malformed value {value!r} ({error})"
            ) from error


# ====================================================================== whole-body kinematics


class LegIK:
    """Damped CLIK on one leg's six joints for its sole pose (pinocchio, LOCAL frame)."""

    def __init__(self, robot: Robot, foot: Stance, params: GaitParams) -> None:
        model = robot.pin_model
        self.model = model
        self.data = model.createData()
        self.frame_id = robot.frame_id(robot.sole_frame(foot))
        names = (
            robot.config.left_leg_joints if foot == Stance.LEFT else robot.config.right_leg_joints
        )
        joint_ids = [model.getJointId(n) for n in names]
        self.idx_q = np.array([model.joints[j].idx_q for j in joint_ids])
        self.idx_v = np.array([model.joints[j].idx_v for j in joint_ids])
        self.lower = model.lowerPositionLimit[self.idx_q]
        self.upper = model.upperPositionLimit[self.idx_q]
        self.params = params

    def solve(
        self, q: NDArray[np.float64], target: pin.SE3, orientation_weight: float = 1.0
    ) -> float:
        """Move the leg joints of ``q`` (in place) so the sole reaches ``target``.

        A swing foot uses ``orientation_weight`` < 1: where the joint limits cannot keep it
        level, it pitches rather than missing its position.

        Returns:
            The remaining position error [m].
        """
        model, data = self.model, self.data
        error_m = math.inf
        for _ in range(self.params.ik_max_iterations):
            pin.forwardKinematics(model, data, q)
            current = pin.updateFramePlacement(model, data, self.frame_id)
            i_m_d = current.actInv(target)
            err = pin.log6(i_m_d).vector
            error_m = float(np.linalg.norm(i_m_d.translation))
            rotation_error = float(np.linalg.norm(err[3:]))
            if error_m < self.params.ik_tolerance_m and (
                rotation_error < 1e-6 or orientation_weight < 1.0
            ):
                break
            jac = pin.computeFrameJacobian(model, data, q, self.frame_id, pin.LOCAL)[:, self.idx_v]
            jac = pin.Jlog6(i_m_d.inverse()) @ jac
            weights = np.array(
                [1.0, 1.0, 1.0, orientation_weight, orientation_weight, orientation_weight]
            )
            joints = q[self.idx_q]
            free = np.ones(6, dtype=bool)
            for _pass in range(3):  # active set: joints pinned at a limit drop out
                jac_free = jac * free
                jac_w = jac_free.T * weights
                step = np.linalg.solve(jac_w @ jac_free + 1e-8 * np.eye(6), jac_w @ err)
                pinned = ((joints <= self.lower + 1e-9) & (step < 0)) | (
                    (joints >= self.upper - 1e-9) & (step > 0)
                )
                if not np.any(pinned & free):
                    break
                free &= ~pinned
            q[self.idx_q] = np.clip(q[self.idx_q] + step, self.lower, self.upper)
        return error_m


def _planar_se3(pose: ArrayLike) -> pin.SE3:
    x, y, z, yaw = (float(v) for v in pose)
    return pin.SE3(pin.utils.rpyToMatrix(0.0, 0.0, yaw), np.array([x, y, z]))


class _BodyKinematics:
    """Configurations from foot poses: pelvis placement, leg IK, head and arms."""

    def __init__(self, robot: Robot, params: GaitParams) -> None:
        self.robot = robot
        self.params = params
        cfg = robot.config
        q0 = robot.neutral()
        for joint, angle in cfg.arm_pose_rad.items():
            q0[7 + robot.joint_index(joint)] = angle
        soles = robot.frame_transforms(q0, (cfg.left_sole,))
        # yaw of the root relative to the feet (iCub's root x points backwards)
        self.root_yaw_offset = -math.atan2(soles[0][1, 0], soles[0][0, 0])
        # start the legs bent in the knee's natural direction
        for names in (cfg.left_leg_joints, cfg.right_leg_joints):
            idx = robot.pin_model.joints[robot.pin_model.getJointId(names[3])].idx_q
            lo, hi = (
                robot.pin_model.lowerPositionLimit[idx],
                robot.pin_model.upperPositionLimit[idx],
            )
            q0[idx] = 0.5 * lo if abs(lo) > abs(hi) else 0.5 * hi
        self.q = q0
        neutral = robot.neutral()
        sole = robot.frame_transforms(neutral, (cfg.left_sole,))[0]
        self.leg_length_m = float(neutral[2] - sole[2, 3])  # root to sole, legs straight
        self.legs = {foot: LegIK(robot, foot, params) for foot in (Stance.LEFT, Stance.RIGHT)}
        self.neck_yaw = 7 + robot.joint_index(cfg.neck_yaw_joint)
        self.neck_pitch = 7 + robot.joint_index(cfg.neck_pitch_joint)
        model = robot.pin_model
        self.neck_limits = {
            i: (model.lowerPositionLimit[i], model.upperPositionLimit[i])
            for i in (self.neck_yaw, self.neck_pitch)
        }

    def configuration(
        self,
        left: NDArray[np.float64],
        right: NDArray[np.float64],
        pelvis_xy: NDArray[np.float64],
        pelvis_z: float,
        yaw: float,
        look_deg: NDArray[np.float64],
        swing: Stance | None,
    ) -> tuple[NDArray[np.float64], float]:
        q = self.q.copy()
        q[:3] = [pelvis_xy[0], pelvis_xy[1], pelvis_z]
        rotation = pin.utils.rpyToMatrix(0.0, 0.0, yaw + self.root_yaw_offset)
        q[3:7] = pin.Quaternion(rotation).coeffs()
        residual = 0.0
        for foot, pose in ((Stance.LEFT, left), (Stance.RIGHT, right)):
            weight = 1e-6 if foot == swing else 1.0
            residual = max(residual, self.legs[foot].solve(q, _planar_se3(pose), weight))
        for index, value in (
            (self.neck_yaw, math.radians(look_deg[0])),
            (self.neck_pitch, self.robot.config.neck_pitch_sign * math.radians(look_deg[1])),
        ):
            lo, hi = self.neck_limits[index]
            q[index] = min(hi, max(lo, value))
        self.q = q
        return q, residual


def _sample_segment(seg: _Segment, t: float, params: GaitParams):
    """Foot poses, support heights, sway/bob phase, stance and look at time t in a segment."""
    rel = min(max(t - seg.start_s, 0.0), seg.duration_s)
    if seg.swing is None:
        look = seg.look_from + _smoothstep(rel / seg.duration_s) * (seg.look_to - seg.look_from)
        return seg.left_to, seg.right_to, seg.left_to[2], seg.right_to[2], 0.0, None, look
    ds = params.double_support_fraction * seg.duration_s
    if rel <= ds:
        return (
            seg.left_from,
            seg.right_from,
            seg.left_from[2],
            seg.right_from[2],
            0.0,
            None,
            seg.look_to,
        )
    phase = (rel - ds) / (seg.duration_s - ds)
    start = seg.left_from if seg.swing == Stance.LEFT else seg.right_from
    end = seg.left_to if seg.swing == Stance.LEFT else seg.right_to
    travel = _smoothstep((phase - 0.1) / 0.65)
    pose = start + travel * (end - start)
    pose[3] = start[3] + travel * _wrap(end[3] - start[3])
    if phase < 0.35:
        pose[2] = start[2] + _smoothstep(phase / 0.35) * (seg.apex_z - start[2])
    elif phase > 0.75:
        pose[2] = seg.apex_z + _smoothstep((phase - 0.75) / 0.25) * (end[2] - seg.apex_z)
    else:
        pose[2] = seg.apex_z
    surface = start[2] + _smoothstep(phase) * (end[2] - start[2])
    if seg.swing == Stance.LEFT:
        return pose, seg.right_from, surface, seg.right_from[2], phase, Stance.RIGHT, seg.look_to
    return seg.left_from, pose, seg.left_from[2], surface, phase, Stance.LEFT, seg.look_to


def plan_route(
    robot: Robot,
    start_pose_xy_yaw: ArrayLike,
    route_steps: Sequence[Any],
    support_height_m: SupportHeightFn,
    frame_rate_hz: float,
    params: GaitParams | None = None,
) -> Trajectory:
    """Plan a kinematic walk along a route and sample it at the frame rate.

    Args:
        robot: The humanoid (`fogsim.robot.model.load_robot`).
        start_pose_xy_yaw: (x [m], y [m], yaw [deg]) of the robot frame at the start.
        route_steps: Route steps (see module docstring).
        support_height_m: Height [m] of the highest standing surface at (N, 2) world xy.
        frame_rate_hz: Sample rate of the trajectory [Hz].
        params: Gait parameters (defaults suit iCub).

    Returns:
        The trajectory; deterministic for the same inputs.

    Raises:
        RouteError: Malformed route step, or no flat footstep where the route goes.
    """
    params = params or GaitParams()
    if not frame_rate_hz > 0.0:
        raise RouteError(f"frame_rate_hz must be > 0, got {frame_rate_hz}")
    start = np.asarray(start_pose_xy_yaw, dtype=np.float64).reshape(-1)
    if start.size != 3 or not np.all(np.isfinite(start)):
        raise RouteError(f"start pose must be (x, y, yaw_deg), got {start_pose_xy_yaw!r}")
    planner = _Planner(robot, params, support_height_m)
    planner.start(start[0], start[1], math.radians(start[2]))
    planner._hold(params.look_transition_s)  # settle: stand still, head at the default look
    _apply_route(planner, route_steps)
    planner._hold(params.look_transition_s)
    segments = planner.segments
    duration = planner.time_s
    times = np.arange(0.0, duration + 1e-9, 1.0 / frame_rate_hz)
    body = _BodyKinematics(robot, params)
    nominal = robot.config.nominal_pelvis_height_m
    q_all = np.empty((times.size, robot.nq))
    pose_true = np.empty((times.size, 4))
    stance = np.empty(times.size, dtype=np.int8)
    looks = np.empty((times.size, 2))
    residuals = np.empty(times.size)
    seg_index = 0
    offset = robot.config.sole_center_offset_m
    reach = body.leg_length_m - params.leg_reach_margin_m
    for i, t in enumerate(times):
        while seg_index + 1 < len(segments) and t >= segments[seg_index + 1].start_s - 1e-12:
            seg_index += 1
        left, right, h_left, h_right, phase, support, look = _sample_segment(
            segments[seg_index], float(t), params
        )
        centres = [
            p[:2] + offset * np.array([math.cos(p[3]), math.sin(p[3])]) for p in (left, right)
        ]
        pelvis_xy = 0.5 * (centres[0] + centres[1])
        yaw = left[3] + 0.5 * _wrap(right[3] - left[3])
        bob = 0.0
        if support is not None:
            towards = centres[0 if support == Stance.LEFT else 1] - pelvis_xy
            norm = float(np.linalg.norm(towards))
            if norm > 1e-9:
                pelvis_xy = pelvis_xy + params.sway_m * math.sin(math.pi * phase) * towards / norm
            bob = params.bob_m * math.sin(math.pi * phase)
        pelvis_z = nominal + 0.5 * (h_left + h_right) + bob
        for pose in (left, right):  # keep both legs short of full extension
            d = float(np.linalg.norm(pose[:2] - pelvis_xy))
            pelvis_z = min(pelvis_z, pose[2] + math.sqrt(max(reach * reach - d * d, 0.0)))
        swing = None if support is None else Stance(1 - int(support))
        q, residual = body.configuration(left, right, pelvis_xy, pelvis_z, yaw, look, swing)
        q_all[i] = q
        residuals[i] = residual
        stance[i] = int(Stance.DOUBLE if support is None else support)
        looks[i] = look
    reference = np.where(stance == Stance.RIGHT, Stance.RIGHT, Stance.LEFT).astype(np.int8)
    for i in range(times.size):
        pose_true[i] = robot.robot_frame_in_world(q_all[i], Stance(int(reference[i])))
    worst = float(residuals.max()) if residuals.size else 0.0
    if worst > 1e-3:
        raise RouteError(f"leg IK could not reach a footstep (residual {worst * 1e3:.1f} mm)")
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
