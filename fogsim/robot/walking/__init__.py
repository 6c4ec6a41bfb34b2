"""Kinematic walking: a scripted route becomes footsteps over the terrain, then joint trajectories.

Modules, in the order a walk is planned: `limits` (the longest walk, the IK tolerance), `gait`
(parameters), `route` (route steps → checked planner commands within a frame budget),
`footsteps` (the footstep planner over the terrain), `timeline` (where the feet are at a time),
`leg_ik` and `body` (whole-body configurations), `trajectory` (`plan_route`: the walk sampled at
the frame rate).
"""

from fogsim.robot.walking.footsteps import Footstep, SupportHeightFn
from fogsim.robot.walking.gait import GaitParams
from fogsim.robot.walking.route import RouteStepInput
from fogsim.robot.walking.trajectory import Trajectory, plan_route

__all__ = [
    "Footstep",
    "GaitParams",
    "RouteStepInput",
    "SupportHeightFn",
    "Trajectory",
    "plan_route",
]
