"""The scenario's planned walk, kept on disk by content (``$FOGSIM_CACHE/routes`` or ~/.cache).

Planning the stage's walk (footsteps on the surfaces the truth reports, leg inverse kinematics
for each of its 832 frames) takes about half a second, the same for every seed and camera mode:
:func:`planned_route` keeps the :class:`~fogsim.robot.Trajectory` under a key of everything
:func:`~fogsim.robot.plan_route` is given (:mod:`fogsim.robot.disk_cache`), and a later run
loads it in milliseconds, the same arrays to the bit.
"""

from __future__ import annotations

from pathlib import Path

import fogsim.config
import fogsim.robot
import fogsim.world
from fogsim.config import Scenario
from fogsim.robot import Robot, Trajectory, plan_route
from fogsim.robot.disk_cache import content_key, library_versions, load_or_build, source_digest
from fogsim.robot.mjcf import cache_root
from fogsim.world import SceneTruth

MAX_CACHED_ROUTES = 64
"""Most planned walks kept, the least recently used removed first: the shipped scenarios with
both robots and room for edited routes (the stage's walk is ~260 kB: the folder stays under
~20 MB)."""
_LIBRARIES = ("pin", "numpy")
"""The packages the plan computes with: pinocchio's kinematics and numpy."""


def route_key(scenario: Scenario, robot: Robot) -> str:
    """Content key of the scenario's walk: everything :func:`planned_route` plans it from.

    The ``[robot]`` table (model, start), the route, the frame rate, the objects and events
    (the surfaces' heights at the start) and every terrain's image, the robot's description,
    the versions of :data:`_LIBRARIES` and the source of ``fogsim.robot`` (the planner and the
    robot model), ``fogsim.world`` (the truth's heights) and ``fogsim.config`` (the scenario's
    meaning). The seed, the camera and the encoders do not enter the walk.
    """
    inputs = (
        scenario.robot,
        scenario.route,
        scenario.frame_rate_hz,
        scenario.objects,
        scenario.events,
        robot.description,
    )
    terrains = tuple(
        obj.heightfield_m().tobytes() for obj in scenario.objects if obj.heightfield is not None
    )
    packages = (fogsim.robot, fogsim.world, fogsim.config)
    return content_key(
        (
            repr(inputs).encode(),
            *terrains,
            library_versions(*_LIBRARIES),
            source_digest(*(Path(package.__file__).parent for package in packages)),
        )
    )


def planned_route(scenario: Scenario, robot: Robot) -> Trajectory:
    """The walk of ``scenario`` by ``robot`` (:func:`~fogsim.robot.plan_route`), cached on disk.

    Raises:
        RouteError: The route cannot be walked (nothing is cached then).
        FogsimError: A cached file cannot be read.
    """

    def plan() -> Trajectory:
        return plan_route(
            robot,
            scenario.robot.start,
            scenario.route,
            SceneTruth.from_scenario(scenario, 0.0).support_height_m,
            scenario.frame_rate_hz,
            origin=scenario.origin,
        )

    path = cache_root().parent / "routes" / f"{scenario.name}_{route_key(scenario, robot)}.pickle"
    return load_or_build(path, plan, MAX_CACHED_ROUTES)
