"""The footstep planner: route commands become footsteps over the terrain and timeline segments.

Footstep rule: each footstep puts the whole sole (plus a margin) on one surface. The planner
tries the nominal step first, then shorter ones, then longer ones up to ``max_step_m``, so the
robot steps over the sill and takes every stair tread with both feet when it must.

Foot poses are sole-origin poses (x, y, z [m], yaw [rad]) in the world.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from fogsim.errors import RouteError
from fogsim.robot.kinematics import Robot, Stance
from fogsim.robot.planar import mean_angle, wrap_angle
from fogsim.robot.walking.gait import GaitParams
from fogsim.robot.walking.timeline import Segment

SupportHeightFn = Callable[[NDArray[np.float64]], NDArray[np.float64]]
"""Height [m] of the highest standing surface at (N, 2) world xy [m]."""


@dataclass(frozen=True)
class Footstep:
    """One planned footstep: sole pose (x, y, z [m], yaw [rad]) in the world."""

    foot: Stance
    pose: tuple[float, float, float, float]


class FootstepPlanner:
    """Turns route commands into timeline segments and footsteps.

    Args:
        robot: The humanoid (its feet and sole frames).
        params: Gait parameters.
        support_height_m: The terrain.
    """

    def __init__(self, robot: Robot, params: GaitParams, support_height_m: SupportHeightFn) -> None:
        self.params = params
        self.support = support_height_m
        feet = robot.description.feet
        self.centre_offset = feet.center_offset_m
        back, front = feet.length_m
        margin = params.footprint_margin_m
        xs = np.linspace(back - margin, front + margin, 9)
        ys = np.linspace(-feet.half_width_m - margin, feet.half_width_m + margin, 3)
        gx, gy = np.meshgrid(xs, ys)
        self.footprint_sole = np.stack([gx.ravel(), gy.ravel()], axis=1)  # in the sole frame
        soles = robot.frame_transforms(robot.neutral(), (feet.left_sole, feet.right_sole))
        self.half_width = 0.5 * float(np.linalg.norm(soles[0][:2, 3] - soles[1][:2, 3]))
        self.segments: list[Segment] = []
        self.footsteps: list[Footstep] = []
        self.route_step: int | None = None  # the route step being planned (Segment.route_step)
        self.time_s = 0.0
        self.look = np.asarray(params.look_default_deg, dtype=np.float64)
        self.left = np.zeros(4)
        self.right = np.zeros(4)

    # -------------------------------------------------------------- terrain queries
    def _footprint_heights(self, sole_pose: NDArray[np.float64]) -> NDArray[np.float64]:
        x, y, _, yaw = (float(v) for v in sole_pose)
        c, s = math.cos(yaw), math.sin(yaw)
        pts = self.footprint_sole
        world = np.column_stack(
            [x + c * pts[:, 0] - s * pts[:, 1], y + s * pts[:, 0] + c * pts[:, 1]]
        )
        return np.asarray(self.support(world), dtype=np.float64).reshape(-1)

    def _flat_height(self, sole_pose: NDArray[np.float64]) -> float | None:
        heights = self._footprint_heights(sole_pose)
        if float(heights.max() - heights.min()) > self.params.flat_tolerance_m:
            return None
        return float(np.median(heights))

    def _sole_at(
        self, centre_xy: NDArray[np.float64] | tuple[float, float], yaw: float, side: Stance
    ) -> NDArray[np.float64]:
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
        return mean_angle(self.left[3], self.right[3])

    # -------------------------------------------------------------- segments
    def start(self, x: float, y: float, yaw: float) -> None:
        """Put both feet down beside (x, y) [m], facing yaw [rad]."""
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

    def hold(self, duration_s: float, look_to: NDArray[np.float64] | None = None) -> None:
        """Stand for ``duration_s`` [s], turning the head to ``look_to`` [deg] if given."""
        target = self.look if look_to is None else look_to
        self.segments.append(
            Segment(
                self.time_s, duration_s, None, self.left.copy(), self.left.copy(),
                self.right.copy(), self.right.copy(), 0.0, self.look.copy(), target.copy(),
                self.route_step,
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
            pose[3] = start[3] + f * wrap_angle(target[3] - start[3])
            highest = max(highest, float(self._footprint_heights(pose).max()))
        new_left = target.copy() if foot == Stance.LEFT else self.left.copy()
        new_right = target.copy() if foot == Stance.RIGHT else self.right.copy()
        self.segments.append(
            Segment(
                self.time_s, self.params.step_period_s, foot, self.left.copy(), new_left,
                self.right.copy(), new_right, highest + self.params.swing_clearance_m,
                self.look.copy(), self.look.copy(), self.route_step,
            )
        )  # fmt: skip
        self.time_s += self.params.step_period_s
        self.left, self.right = new_left, new_right
        x, y, z, yaw = (float(v) for v in target)
        self.footsteps.append(Footstep(foot, (x, y, z, yaw)))

    def _place(
        self, foot: Stance, centre_xy: NDArray[np.float64], yaw: float
    ) -> NDArray[np.float64]:
        pose = self._sole_at(centre_xy, yaw, foot)
        height = self._flat_height(pose)
        if height is None:
            raise RouteError(
                f"no flat place for the {foot.name} foot near ({centre_xy[0]:.3f}, "
                f"{centre_xy[1]:.3f}) while turning; turn on flat ground"
            )
        pose[2] = height
        return pose

    # -------------------------------------------------------------- durations
    def _turn_pairs(self, delta: float) -> int:
        """Pairs of steps that turn the body by ``delta`` [rad] (0 for no turn)."""
        if abs(delta) < 1e-9:
            return 0
        return max(1, math.ceil(abs(delta) / math.radians(self.params.turn_step_deg)))

    def turn_duration_s(self, yaw: float) -> float:
        """How long :meth:`turn_to` ``yaw`` [rad] takes from here [s] (exact)."""
        pairs = self._turn_pairs(wrap_angle(yaw - self._heading()))
        return 2 * pairs * self.params.step_period_s

    def min_walk_duration_s(self, x: float, y: float) -> float:
        """A lower bound of how long :meth:`walk_to` (x, y) [m] takes from here [s].

        A foot lands at most ``max_step_m`` ahead of the other, so k steps advance the feet at
        most k · ``max_step_m``; the walk ends with both feet at the goal, or (goal not flat)
        at most one such step short of it. Turns towards the goal are not counted.
        """
        distance = float(np.linalg.norm(np.array([x, y]) - self._centre()))
        return max(0.0, distance / self.params.max_step_m - 1.0) * self.params.step_period_s

    # -------------------------------------------------------------- route commands
    def turn_to(self, yaw: float) -> None:
        """Turn in place to face yaw [rad], in pairs of steps of at most ``turn_step_deg``."""
        heading = self._heading()
        delta = wrap_angle(yaw - heading)
        n = self._turn_pairs(delta)
        if n == 0:
            return
        centre = self._centre()
        first, second = (Stance.LEFT, Stance.RIGHT) if delta > 0 else (Stance.RIGHT, Stance.LEFT)
        for i in range(1, n + 1):
            new_yaw = heading + delta * i / n
            for foot in (first, second):
                self._step(foot, self._place(foot, centre, new_yaw))

    def walk_to(self, x: float, y: float) -> None:
        """Walk the robot centre to (x, y) [m] (turning towards it first if needed)."""
        centre = self._centre()
        offset = np.array([x, y]) - centre
        distance = float(np.linalg.norm(offset))
        if distance < 1e-6:
            return
        yaw = math.atan2(offset[1], offset[0])
        if abs(wrap_angle(yaw - self._heading())) > math.radians(self.params.heading_tolerance_deg):
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
        """Stand while the head turns to (yaw, pitch) [deg] relative to the body."""
        self.hold(self.params.look_transition_s, np.array([yaw_deg, pitch_deg], dtype=float))

    def wait(self, seconds: float) -> None:
        """Stand still for ``seconds``."""
        self.hold(seconds)
