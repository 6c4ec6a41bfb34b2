"""Leg inverse kinematics: the six leg joints that put a sole at a pose (pinocchio CLIK)."""

import math

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from fogsim.robot.kinematics import Robot, Stance
from fogsim.robot.walking.gait import GaitParams


class LegIK:
    """Damped CLIK on one leg's six joints for its sole pose (pinocchio, LOCAL frame).

    Args:
        robot: The humanoid (its own pinocchio data is used, so the robot's stays untouched).
        foot: The leg (LEFT or RIGHT).
        params: Gait parameters (IK tolerance and iterations).
    """

    def __init__(self, robot: Robot, foot: Stance, params: GaitParams) -> None:
        model = robot.pin_model
        self.model = model
        self.data = model.createData()
        self.frame_id = robot.frame_id(robot.sole_frame(foot))
        legs = robot.description.legs
        names = legs.left_joints if foot == Stance.LEFT else legs.right_joints
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
