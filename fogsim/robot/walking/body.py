"""Body kinematics: whole-body configurations (root, legs, head, arms) from foot poses."""

import math

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from fogsim.robot.kinematics import Robot, Stance
from fogsim.robot.planar import yaw_of
from fogsim.robot.walking.gait import GaitParams
from fogsim.robot.walking.leg_ik import LegIK


class BodyKinematics:
    """Whole-body configurations from foot and pelvis poses: leg IK, head and arms.

    Warm started: each configuration starts from the previous one (legs bent at first).

    Args:
        robot: The humanoid.
        params: Gait parameters.
    """

    def __init__(self, robot: Robot, params: GaitParams) -> None:
        description = robot.description
        self.neck_pitch_sign = description.neck.pitch_sign
        left_sole = description.feet.left_sole
        q0 = robot.neutral()
        for joint, angle in description.arm_pose_rad.items():
            q0[7 + robot.joint_index(joint)] = angle
        soles = robot.frame_transforms(q0, (left_sole,))
        # yaw of the root relative to the feet (iCub's root x points backwards)
        self.root_yaw_offset = -yaw_of(soles[0])
        # start the legs bent in the knee's natural direction
        for names in (description.legs.left_joints, description.legs.right_joints):
            idx = robot.pin_model.joints[robot.pin_model.getJointId(names[3])].idx_q
            lo, hi = (
                robot.pin_model.lowerPositionLimit[idx],
                robot.pin_model.upperPositionLimit[idx],
            )
            q0[idx] = 0.5 * lo if abs(lo) > abs(hi) else 0.5 * hi
        self.q = q0
        neutral = robot.neutral()
        sole = robot.frame_transforms(neutral, (left_sole,))[0]
        self.leg_length_m = float(neutral[2] - sole[2, 3])  # root to sole, legs straight
        self.legs = {foot: LegIK(robot, foot, params) for foot in (Stance.LEFT, Stance.RIGHT)}
        self.neck_yaw = 7 + robot.joint_index(description.neck.yaw_joint)
        self.neck_pitch = 7 + robot.joint_index(description.neck.pitch_joint)
        # A route's looks are within reach (`plan_route` refuses others): the clamp only
        # keeps the rounding of a look at exactly the limit inside it.
        neck = description.neck
        self.neck_limits = {
            self.neck_yaw: robot.joint_limits_rad(neck.yaw_joint),
            self.neck_pitch: robot.joint_limits_rad(neck.pitch_joint),
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
        """The configuration for these sole poses, pelvis and look, and the IK residual.

        Args:
            left: Left sole pose (x, y, z [m], yaw [rad]) in the world.
            right: Right sole pose.
            pelvis_xy: Root position (x, y) in the world [m].
            pelvis_z: Root height [m].
            yaw: Body yaw in the world [rad].
            look_deg: Head (yaw, pitch) relative to the body [deg].
            swing: The swinging foot (kept level less strictly), or None.

        Returns:
            The pinocchio configuration and the larger leg IK position residual [m].
        """
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
            (self.neck_pitch, self.neck_pitch_sign * math.radians(look_deg[1])),
        ):
            lo, hi = self.neck_limits[index]
            q[index] = min(hi, max(lo, value))
        self.q = q
        return q, residual


def _planar_se3(pose: NDArray[np.float64]) -> pin.SE3:
    """A level pose (x, y, z [m], yaw [rad]) as an SE3."""
    x, y, z, yaw = (float(v) for v in pose)
    return pin.SE3(pin.utils.rpyToMatrix(0.0, 0.0, yaw), np.array([x, y, z]))
