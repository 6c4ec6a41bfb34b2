"""Layer 4 — the robot: its description, kinematics, walking, encoders, odometry and self-filter.

Modules: `description` (the data file of each robot), `mjcf` (the pinocchio → MJCF converter and
its cache), `kinematics` (`Robot`: frames and forward kinematics), `model` (`load_robot`),
`walking` (route → trajectory), `encoders`, `odometry`, `self_filter`; helpers `planar`,
`meshes`, `body_boxes`.
"""

from fogsim.lazy import lazy_getattr

_EXPORTS = {
    "BodyBox": "fogsim.robot.body_boxes",
    "CAMERA_NAMES": "fogsim.robot.description",
    "ROBOT_NAMES": "fogsim.robot.description",
    "RobotDescription": "fogsim.robot.description",
    "load_description": "fogsim.robot.description",
    "read_description": "fogsim.robot.description",
    "EncoderModel": "fogsim.robot.encoders",
    "Footstep": "fogsim.robot.walking",
    "GaitParams": "fogsim.robot.walking",
    "JointGroup": "fogsim.robot.encoders",
    "Odometry": "fogsim.robot.odometry",
    "Robot": "fogsim.robot.kinematics",
    "SelfFilter": "fogsim.robot.self_filter",
    "SelfFilterParams": "fogsim.robot.self_filter",
    "Stance": "fogsim.robot.kinematics",
    "Trajectory": "fogsim.robot.walking",
    "joint_groups": "fogsim.robot.encoders",
    "load_robot": "fogsim.robot.model",
    "plan_route": "fogsim.robot.walking",
}
"""The package's names and their modules, imported on first use: a replay reads the
robot's description (:mod:`~fogsim.robot.description`) without pinocchio, MuJoCo or dm_control."""

__all__ = sorted(_EXPORTS)

__getattr__ = lazy_getattr(__name__, _EXPORTS)
