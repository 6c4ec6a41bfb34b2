"""Layer 4 — the robot: its description, kinematics, walking, encoders, odometry and self-filter.

Modules: `description` (the data file of each robot), `mjcf` (the pinocchio → MJCF converter and
its cache), `kinematics` (`Robot`: frames and forward kinematics), `model` (`load_robot`),
`walking` (route → trajectory), `encoders`, `odometry`, `self_filter`; helpers `planar`,
`meshes`, `body_boxes`.
"""

from fogsim.robot.body_boxes import BodyBox
from fogsim.robot.description import (
    CAMERA_NAMES,
    ROBOT_NAMES,
    RobotDescription,
    load_description,
    read_description,
)
from fogsim.robot.encoders import EncoderModel, JointGroup, joint_groups
from fogsim.robot.kinematics import Robot, Stance
from fogsim.robot.model import load_robot
from fogsim.robot.odometry import Odometry
from fogsim.robot.self_filter import SelfFilter, SelfFilterParams
from fogsim.robot.walking import Footstep, GaitParams, Trajectory, plan_route

__all__ = [
    "CAMERA_NAMES",
    "ROBOT_NAMES",
    "BodyBox",
    "EncoderModel",
    "Footstep",
    "GaitParams",
    "JointGroup",
    "Odometry",
    "Robot",
    "RobotDescription",
    "SelfFilter",
    "SelfFilterParams",
    "Stance",
    "Trajectory",
    "joint_groups",
    "load_description",
    "load_robot",
    "plan_route",
    "read_description",
]
